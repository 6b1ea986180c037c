"""``esair emulate starfish``: served on a real pty (driven with pySerial and with ``esair
send``), run headless, its trace, and the options it refuses."""

from __future__ import annotations

import contextlib
import os
import select
import signal
import subprocess
import sys
import time
from pathlib import Path

import serial
from click.testing import CliRunner

from esair_min.cli import main
from esair_min.emulator.starfish_trace import read_trace

ROOT = Path(__file__).resolve().parents[2]
START_TIMEOUT = 30
VERSION = "OK esair-min/1 starfish wheels=3 flow=2 watchdog=500 checksum=off"


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    return env


@contextlib.contextmanager
def emulator(*args: str):
    proc = subprocess.Popen(
        [sys.executable, "-m", "esair_min.cli", "emulate", "starfish", "--pty", *args],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=_env())
    try:
        ready, _, _ = select.select([proc.stdout], [], [], START_TIMEOUT)
        assert ready, "the emulator printed no pty path"
        path = proc.stdout.readline().decode().strip()
        assert path.startswith("/dev/"), path
        yield proc, path
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=10) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=10)
        proc.stdout.close()
        proc.stderr.close()


def ask(port: serial.Serial, line: str) -> str:
    """Send a line, return its reply (skipping the boot's !READY, which the port carries
    only if it was opened in time)."""
    port.write(line.encode() + b"\r\n")
    while True:
        got = port.readline()
        assert got.endswith(b"\r\n"), f"no reply to {line!r} (got {got!r})"
        if got != b"!READY esair-min/1 starfish\r\n":
            return got.decode().rstrip("\r\n")


def test_driven_over_the_pty_until_the_watchdog_stops_it(tmp_path):
    trace = tmp_path / "starfish.trace"
    with emulator("--speed", "4", "--trace", str(trace)) as (_, path), \
            serial.Serial(path, 9600, timeout=5) as port:
        assert ask(port, "v") == VERSION
        assert ask(port, "V+0200+0000+0000") == "OK"
        first = ask(port, "O")
        time.sleep(0.1)                                   # 0.4 s of virtual time
        second = ask(port, "O")
        assert first.startswith("OK n=") and second.startswith("OK n=")
        moved = int(second.split()[2].split("=")[1].split(",")[0])
        assert moved > 0                                  # the left flow sensor counted
        assert port.readline() == b"!W watchdog stop\r\n"   # nothing sent for 500 ms
        time.sleep(0.2)                                   # ramped down in 0.1 s virtual
    rows = read_trace(trace)
    assert len(rows.room.walls) == 4 and rows.t == sorted(rows.t)
    assert max(rows.x) > 2550 and rows.wheels[-1] == (0.0, 0.0, 0.0)


def test_esair_send_drives_it():
    with emulator() as (_, path):
        run = subprocess.run(
            [sys.executable, "-m", "esair_min.cli", "send", path, "v", "W+0100+0100+0100",
             "x", "V+0900+0000+0000", "t"],
            cwd=ROOT, env=_env(), capture_output=True, timeout=60)
        assert run.stdout.decode().splitlines() == [
            VERSION, "OK", "OK", "E04 outside limits", "E01 unknown command"]
        assert run.returncode == 1


def test_headless_run_prints_the_replies_and_the_pose(tmp_path):
    result = CliRunner().invoke(main, ["emulate", "starfish", "--run", "2", "--send",
                                       "V+0000+0200+0000", "--send", "v"])
    assert result.exit_code == 0, result.output
    assert result.stdout.splitlines() == ["!READY esair-min/1 starfish", "OK", VERSION,
                                          "!W watchdog stop"]
    assert result.stderr.startswith("pose after 2 s: x 2500.")
    assert ", y 2598." in result.stderr and result.stderr.endswith("wall contacts 0\n")


def test_room_file_and_refused_options(tmp_path):
    room = Path("tests/fixtures/rooms/lab.yaml")
    result = CliRunner().invoke(main, ["emulate", "starfish", "--run", "0.1", "--room",
                                       str(room)])
    assert result.exit_code == 0
    assert "pose after 0.1 s: x 3000.0 mm, y 2000.0 mm" in result.stderr
    for args, message in [
        (["--scenario", "push"], "--scenario: not for a robot with an omni base (STARFISH), "
         "whose sensors and faults are its room's (docs/emulator.md)"),
        (["--stuck-bus"], "the fault options: not for a robot with an omni base (STARFISH), "
         "whose sensors and faults are its room's (docs/emulator.md)"),
    ]:
        result = CliRunner().invoke(main, ["emulate", "starfish", "--run", "1", *args])
        assert (result.exit_code, result.stderr) == (1, f"error: {message}\n")
    result = CliRunner().invoke(main, ["emulate", "papaman", "--run", "1", "--room",
                                       str(room)])
    assert (result.exit_code, result.stderr) == (
        1, "error: --room is for a robot with an omni base (STARFISH); this robot has none\n")


def test_generate_first(tmp_path):
    result = CliRunner().invoke(main, ["emulate", "starfish", "--run", "0.1", "--generate",
                                       str(tmp_path / "fw")])
    assert result.exit_code == 0
    assert result.stderr.startswith(f"generated starfish into {tmp_path / 'fw'}\n")
    assert (tmp_path / "fw" / "drive" / "core" / "drive.c").is_file()


def test_trace_and_plot_of_a_headless_run(tmp_path):
    trace, png = tmp_path / "run.trace", tmp_path / "run.png"
    result = CliRunner().invoke(main, ["emulate", "starfish", "--run", "1", "--trace",
                                       str(trace), "--send", "V+0300+0000+0000"])
    assert result.exit_code == 0
    tr = read_trace(trace)
    assert len(tr.t) == 100 and tr.t[-1] == 0.999040     # ticks of 9.9904 ms
    assert tr.x[-1] > 2600 and tr.contacts == []
    result = CliRunner().invoke(main, ["plot", str(trace), "-o", str(png)])
    assert (result.exit_code, result.output) == (0, f"100 ticks -> {png}\n")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    trace.write_text("# esair-starfish-trace 1\n@1.0 2 3\n")
    result = CliRunner().invoke(main, ["plot", str(trace), "-o", str(png)])
    assert (result.exit_code, result.stderr) == (
        1, f"error: {trace}:2: not a STARFISH trace line: '@1.0 2 3'\n")
