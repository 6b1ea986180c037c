"""One CLI manner (issue 10 item 5): every option works or is refused with a reason.

Run as a user would: real processes, real pipes, real ptys, and miniterm typed into.
Option refusals of `esair emulate` and `esair send` are in tests/min/test_send.py.
"""

from __future__ import annotations

import contextlib
import os
import select
import signal
import subprocess
import sys
import termios
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from esair_min.cli import main
from tests.support.board_lines import READY_OK_T, VERSION_OK_T

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
VERSION = VERSION_OK_T
INSTANCE = "0123abcd"            # the pty emulators here boot with this instance
VERSION_PTY = f"{VERSION} id={INSTANCE}"


def _env() -> dict[str, str]:
    return dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))


def esair(*args: str) -> list[str]:
    return [sys.executable, "-m", "esair_min.cli", *args]


def run(*args: str):
    return CliRunner().invoke(main, list(args))


# -- robots named wrong, and lone board files --------------------------------------------

@pytest.mark.parametrize("command", ["emulate", "check"])
def test_a_misspelt_example_gets_a_did_you_mean_and_no_invented_position(command):
    r = run(command, "papman", "--run", "1") if command == "emulate" else run(command, "papman")
    assert r.exit_code == 1
    assert r.output == ("error: papman: no such file or folder, and no bundled example "
                        "robot of that name (did you mean 'papaman'?)\n")


def test_a_missing_path_names_the_path_only():
    r = run("emulate", "robots/mine", "--run", "1")
    assert (r.exit_code, r.output) == (1, "error: robots/mine: no such file or folder\n")


@pytest.mark.parametrize("board, first", [
    ("actuator", "board 'actuator' [actuator], I2C slave at 0x10: servos: 12"),
    ("sensor", "board 'sensor' [sensor], I2C slave at 0x20: sensors: 8"),
    ("central", "board 'central' [central], I2C master: commands: 15, motions: 5, reactions: 1"),
])
def test_check_a_lone_board_file_on_its_own_rules(board, first, monkeypatch):
    monkeypatch.chdir(ROOT)
    r = run("check", f"boards/papaman/{board}.yaml")
    assert r.exit_code == 0, r.output
    assert r.output.splitlines() == [
        first,
        "  checked on its own: the rules between boards (addresses, register counts, "
        "motions against servos, reactions against sensor groups) need all of the robot's "
        "board files: esair check boards/papaman",
        "ok"]


def test_a_lone_board_file_is_still_checked(tmp_path):
    f = tmp_path / "actuator.yaml"
    text = (ROOT / "boards/papaman/actuator.yaml").read_text()
    f.write_text(text.replace("index: 11", "index: 12"))
    r = run("check", str(f))
    assert r.exit_code == 1
    assert r.output.startswith(f"error: {f}:")
    assert r.output.endswith("index 12 leaves a gap; servo indices must run 0..11 and index "
                             "11 is missing\n")


def test_a_lone_peer_board_is_not_a_robot_to_emulate(monkeypatch):
    monkeypatch.chdir(ROOT)
    r = run("emulate", "boards/papaman/sensor.yaml", "--run", "1")
    assert (r.exit_code, r.output) == (
        1, "error: boards/papaman/sensor.yaml:4:7: this sensor board alone is not a robot, "
           "which needs its central board too; give the folder that holds all its board "
           "files (boards/papaman)\n")


# -- Ctrl-C during --run, closed pipes ----------------------------------------------------

def test_ctrl_c_during_a_run_keeps_what_ran(tmp_path):
    trace = tmp_path / "t.txt"
    proc = subprocess.Popen(esair("emulate", "papaman", "--run", "100000", "--send", "v",
                                  "--send", "PLY03", "--trace", str(trace)),
                            cwd=ROOT, env=_env(), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    try:
        got = b""
        while got.count(b"\n") < 3:                       # !READY, the version, OK
            ready, _, _ = select.select([proc.stdout], [], [], 30)
            assert ready, got
            got += os.read(proc.stdout.fileno(), 4096)
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 130
    lines = (got + out).decode().splitlines()
    assert lines[:3] == [READY_OK_T, VERSION, "OK"]
    err_text = err.decode()
    assert err_text.startswith("interrupted after ") and "Traceback" not in err_text
    assert err_text.endswith(f"s of the 100000 s run (virtual time): the output so far is "
                             f"printed and the trace {trace} is complete up to there\n")
    text = trace.read_text()
    assert text.startswith("# esair-trace 1\n") and text.endswith("\n")
    assert text.count("\nT ") >= 32                     # the dance ran and was written


@pytest.mark.parametrize("argv", [
    [sys.executable, "-m", "esair_min.harness", "papaman", "SCRIPT"],
    esair("emulate", "papaman", "--run", "60", "--send", "PLY03", "--trace", "/dev/stdout"),
])
def test_a_closed_pipe_ends_quietly(argv, tmp_path):
    script = tmp_path / "s.txt"
    # more than a pipe holds (331 KB; the emulator's run: 184 KB), or a slow `head` lets
    # the writer finish into the pipe's 64 KiB and exit 0
    script.write_text("boot\nrx PLY03\\r\ntick 20000\n")
    argv = [str(script) if a == "SCRIPT" else a for a in argv]
    writer = subprocess.Popen(argv, cwd=ROOT, env=_env(), stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE)
    head = subprocess.run(["head", "-n", "1"], stdin=writer.stdout, capture_output=True,
                          timeout=60)
    writer.stdout.close()
    err = writer.stderr.read()
    writer.stderr.close()
    assert writer.wait(timeout=60) == 141             # 128 + SIGPIPE, as a shell reports
    assert err == b""
    assert head.stdout.count(b"\n") == 1


# -- the pty: a serial line that only carries bytes while a program has it open -----------

@contextlib.contextmanager
def served(*args: str):
    proc = subprocess.Popen(esair("emulate", "papaman", "--pty", "--instance", INSTANCE, *args), cwd=ROOT,
                            env=_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        ready, _, _ = select.select([proc.stdout], [], [], 30)
        assert ready, "no pty path"
        yield proc.stdout.readline().decode().strip()
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=10) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        proc.stdout.close()
        proc.stderr.close()


def wait_for_line(path: Path, line: str, timeout: float = 20) -> None:
    """Wait until ``line`` is in the trace file, read while the emulator writes it."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if path.exists() and line in path.read_text().splitlines():
            return
        time.sleep(0.05)
    raise AssertionError(f"{line!r} never reached {path}")


def wait_past(path: Path, line: str, us: int, timeout: float = 20) -> None:
    """Wait until the trace's virtual time is ``us`` past ``line`` (its bytes are on
    the wire meanwhile: a line of 17 characters takes 17.7 ms at 9600 baud)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        mark, at = 0, None
        for ln in path.read_text().splitlines():
            if ln.startswith("@ "):
                mark = int(ln[2:])
                if at is not None and mark >= at + us:
                    return
            elif ln == line and at is None:
                at = mark
        time.sleep(0.05)
    raise AssertionError(f"the trace never went {us} us past {line!r}")


def raw_open(path: str) -> int:
    """Open the port as picocom or a C program does: no flush of what waits in it."""
    return os.open(path, os.O_RDWR | os.O_NOCTTY)


def first_line(fd: int, timeout: float = 10) -> bytes:
    got = b""
    deadline = time.monotonic() + timeout
    while b"\n" not in got and time.monotonic() < deadline:
        ready, _, _ = select.select([fd], [], [], 0.2)
        if ready:
            got += os.read(fd, 256)
    return got.split(b"\n")[0] + b"\n"


def tx(text: str) -> str:
    return "TX " + text.encode().hex().upper()


def test_a_program_opening_late_reads_no_old_notices_and_the_trace_is_live(tmp_path):
    trace = tmp_path / "t.txt"
    with served("--scenario", "push", "--trace", str(trace)) as path:
        # the trace is written line by line: the reaction (1.1 s in) shows up while serving
        wait_for_line(trace, tx("!R auto_balance\r\n"))
        # the push (1.1 s to 1.5 s) fires the reaction a few times; all are over 1 s on
        wait_past(trace, tx("!R auto_balance\r\n"), 1_000_000)
        fd = raw_open(path)
        try:
            os.write(fd, b"v\r\n")
            assert first_line(fd) == VERSION_PTY.encode() + b"\r\n"   # no !READY, no !R
        finally:
            os.close(fd)


def test_what_a_program_left_unread_is_gone_for_the_next(tmp_path):
    trace = tmp_path / "t.txt"
    with served("--trace", str(trace)) as path:
        fd = raw_open(path)
        os.write(fd, b"v\r\n")
        time.sleep(0.3)                  # the port stays open while the reply comes
        wait_for_line(trace, tx(VERSION_PTY + "\r\n"))
        os.close(fd)                     # ... and is closed with the reply unread
        time.sleep(0.2)
        fd = raw_open(path)
        try:
            os.write(fd, b"t\r\n")
            assert first_line(fd) == b"OK\r\n"
        finally:
            os.close(fd)


def test_miniterm_as_documented(tmp_path):
    """docs/emulator.md's miniterm line, typed into: local echo, Enter ends the line,
    Backspace reaches the robot as a byte (E13)."""
    doc = (ROOT / "docs" / "emulator.md").read_text()
    assert "python -m serial.tools.miniterm --echo --eol CRLF /dev/pts/4 9600" in doc
    with served() as path:
        term, term_slave = os.openpty()
        mt = subprocess.Popen([sys.executable, "-m", "serial.tools.miniterm", "--echo",
                               "--eol", "CRLF", path, "9600"], stdin=term_slave,
                              stdout=term_slave, stderr=term_slave, env=_env(),
                              start_new_session=True)
        probe = os.open(os.ttyname(term_slave), os.O_RDWR | os.O_NOCTTY)
        os.close(term_slave)
        try:
            def screen(until: bytes) -> bytes:
                got = b""
                deadline = time.monotonic() + 15
                while until not in got and time.monotonic() < deadline:
                    ready, _, _ = select.select([term], [], [], 0.2)
                    if ready:
                        got += os.read(term, 1024)
                return got

            assert b"--- Miniterm on " in screen(b"Ctrl+]")
            deadline = time.monotonic() + 15            # miniterm has set its console up
            while termios.tcgetattr(probe)[3] & termios.ECHO:
                assert time.monotonic() < deadline
                time.sleep(0.05)
            os.write(term, b"v\r")                       # the user types v, Enter
            shown = screen(INSTANCE.encode())
            # the banner's line end may come after the screen above stopped at "Ctrl+]"
            lines = shown.replace(b"\r", b"").split(b"\n")
            assert b"v" in lines, shown
            at = lines.index(b"v")
            assert lines[at:at + 2] == [b"v", VERSION_PTY.encode()]
            os.write(term, b"tx\x7f\r")                  # t, x, Backspace, Enter
            assert b"E13 bad character" in screen(b"E13 bad character")
            os.write(term, b"\x1d")                      # Ctrl+] quits
            assert mt.wait(timeout=10) == 0
        finally:
            if mt.poll() is None:
                mt.kill()
                mt.wait()
            os.close(term)
            os.close(probe)


def test_the_help_names_every_bundled_example():
    from esair_min.resources import bundled_examples

    assert bundled_examples() == ["papaman", "papaman-avr", "starfish", "starfish-avr"]
    out = CliRunner().invoke(main, ["--help"], terminal_width=200)
    assert out.exit_code == 0, out.output
    assert ("the name of a bundled example (papaman, papaman-avr, starfish, starfish-avr)."
            in " ".join(out.output.split()))
