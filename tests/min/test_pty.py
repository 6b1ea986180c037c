"""`esair emulate boards/papaman --pty` driven with pySerial, as a user's program would.

Each test starts the emulator as a subprocess, reads the pty path from the first line
of its output, talks to it with pySerial (locked as ESAIR's programs lock a port:
tests.support.robot_ptys.open_pty), and always stops the child (SIGTERM, then SIGKILL
if it does not exit).
"""

from __future__ import annotations

import contextlib
import math
import os
import select
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import serial

from esair_min.emulator.papaman.actuator import encode
from esair_min.cli.plot import read_trace, replay
from esair_min.core.trace import without_marks
from esair_min.model.validate import load_robot
from tests.support.board_lines import PAPAMAN, text, version
from tests.support.robot_ptys import open_pty

pytestmark = pytest.mark.pty

ROOT = Path(__file__).resolve().parents[2]
START_TIMEOUT = 30
INSTANCE = "0123abcd"            # the emulators here boot with this instance
VERSION = text(version(PAPAMAN, robot_id=INSTANCE))


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    return env


@contextlib.contextmanager
def emulator(*args: str, stop=signal.SIGTERM):
    """Yield (process, pty path); stop the process (and check it exits 0) afterwards."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "esair_min.cli", "emulate", "boards/papaman", "--pty",
         "--instance", INSTANCE, *args],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=_env())
    try:
        ready, _, _ = select.select([proc.stdout], [], [], START_TIMEOUT)
        assert ready, "the emulator printed no pty path"
        path = proc.stdout.readline().decode().strip()
        assert path.startswith("/dev/"), (path, proc.stderr.read() if proc.poll() else "")
        yield proc, path
        proc.send_signal(stop)
        assert proc.wait(timeout=10) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=10)
        proc.stdout.close()
        proc.stderr.close()


def ask(port: serial.Serial, line: str) -> str:
    """Send a line, return its reply (skipping notices)."""
    port.write(line.encode() + b"\r\n")
    while True:
        got = port.readline()
        assert got.endswith(b"\r\n"), f"no reply to {line!r} (got {got!r})"
        text = got.decode().rstrip("\r\n")
        if not text.startswith("!"):
            return text


@pytest.fixture(scope="module")
def robot():
    return load_robot(ROOT / "boards" / "papaman")


def test_commands_replies_and_servo_state(tmp_path, robot):
    trace = tmp_path / "trace.txt"
    with emulator("--trace", str(trace)) as (_, path):
        with open_pty(path, 9600, timeout=3) as port:
            assert ask(port, "v") == VERSION
            assert ask(port, "t") == "OK"
            assert ask(port, "oaf120") == "OK"                 # motor a, speed 5, 120 deg
            assert ask(port, "oab170") == "E04 outside limits"
            assert ask(port, "a" + "001" * 12) == "OK"
            assert ask(port, "c" + "N" * 10 + "P.") == "OK"    # 90 x10, 96, keep
            assert ask(port, "s") == "OK 512,512,512,512,512,512,512,512"
            assert ask(port, "PLY02") == "OK"                  # prostrate, 4 x 25 ticks
            assert ask(port, "t") == "E07 busy"
            assert ask(port, "x") == "OK"
            assert ask(port, "PLY77") == "E08 no such motion"
            assert ask(port, "SIT") == "OK"
            assert ask(port, "x") == "OK"
            assert ask(port, "t*74") == "OK"
            assert ask(port, "t*99") == "E06 bad checksum"
            assert ask(port, "zebra") == "E01 unknown command"
            assert ask(port, "c" + "N" * 10 + "P.") == "OK"
            time.sleep(0.5)                                    # servos reach their targets
    lines = without_marks(trace.read_text().splitlines())
    writes = [ln for ln in lines if ln.startswith("W 10")]
    assert writes[1] == "W 10 001433 ACK"                      # low 20, high 1 + 10*5
    # the angles line: servo 10 to 96 at the speed set by `a` (1), servo 11 kept at 90
    pairs = b"".join(bytes(encode(a, 1)) for a in [90] * 10 + [96, 90])
    assert writes[-1] == f"W 10 00{pairs.hex().upper()} ACK"
    ticks, pos, _ = replay(robot, read_trace(trace, 0x10))
    assert pos[-1] == [90] * 10 + [96, 90]


def test_dance_plays_one_frame_per_tick_in_one_burst(tmp_path):
    trace = tmp_path / "dance.txt"
    with emulator("--trace", str(trace)) as (_, path):
        with open_pty(path, 9600, timeout=3) as port:
            assert ask(port, "PLY03") == "OK"
            # the dance's end, told by the robot (an EEPROM read is refused while it
            # plays), not by a fixed wait the emulator may lag behind on a loaded machine
            deadline = time.monotonic() + 60
            while ask(port, "r000001") == "E07 busy":
                assert time.monotonic() < deadline, "the dance never ended"
                time.sleep(0.05)
            assert ask(port, "v") == VERSION
    tick, per_tick = 0, {}
    for line in without_marks(trace.read_text().splitlines()):
        if line.startswith("T "):
            tick = int(line[2:])
        elif line.startswith("W 10"):
            per_tick.setdefault(tick, []).append(line)
    frames = sorted(per_tick)
    assert len(frames) == 32
    assert frames == list(range(frames[0], frames[0] + 32))      # one frame per tick
    assert all(len(per_tick[t]) == 1 for t in frames)             # in one burst each
    assert all(len(per_tick[t][0].split()[2]) == 50 for t in frames)   # reg 0 + 24 bytes


def test_push_fires_the_balance_reaction_in_time(tmp_path, robot):
    trace = tmp_path / "push.txt"
    with emulator("--scenario", "push", "--trace", str(trace)) as (_, path):
        with open_pty(path, 9600, timeout=0.2) as port:
            seen = b""
            deadline = time.monotonic() + 10
            while b"!R auto_balance\r\n" not in seen and time.monotonic() < deadline:
                seen += port.read(100)
            assert b"!R auto_balance\r\n" in seen
    tick, fired = 0, None
    for line in trace.read_text().splitlines():
        if line.startswith("T "):
            tick = int(line[2:])
        elif line == "TX " + b"!R auto_balance\r\n".hex().upper():
            fired = tick
            break
    reaction = robot.central.reactions[0]
    onset = math.ceil(1.100 / robot.central.timer2.period_s)
    assert fired is not None and 0 <= fired - onset <= reaction.samples * reaction.poll_ticks


def test_a_held_scenario_plays_on_sigusr1(tmp_path):
    f = tmp_path / "lean.yaml"
    f.write_text("idle: 500\nsteps:\n  - {at_ms: 0, values: {left_foot: 600}}\n")
    with emulator("--scenario", str(f), "--hold-scenario") as (proc, path):
        with open_pty(path, 9600, timeout=2) as port:
            assert ask(port, "s") == "OK " + ",".join(["500"] * 8)    # held since boot
            proc.send_signal(signal.SIGUSR1)
            want = "OK " + ",".join(["600"] * 4 + ["500"] * 4)
            deadline = time.monotonic() + 10
            while (got := ask(port, "s")) != want and time.monotonic() < deadline:
                pass
            assert got == want


def test_one_reply_per_line_at_line_rate():
    # back to back, as many lines as the board's rings can absorb the longer replies of
    # (three times over, the receive ring overruns: tests/min/test_emulator.py)
    lines = ["t", "v", "oab100", "s", "zz", "c" + "N" * 12, "x", "PLY09", "a" + "002" * 12,
             "oal100"]
    with emulator() as (_, path):
        with open_pty(path, 9600, timeout=3) as port:
            port.write(b"".join(ln.encode() + b"\r\n" for ln in lines))   # back to back
            replies = []
            while len(replies) < len(lines):
                got = port.readline()
                assert got.endswith(b"\r\n"), f"after {len(replies)} replies: {got!r}"
                if not got.startswith(b"!"):
                    replies.append(got.decode().rstrip())
            assert port.read(1) == b"" or port.in_waiting == 0
    expect = {"v": "OK esair-min/1", "s": "OK 512", "zz": "E01", "PLY09": "E08"}
    for line, reply in zip(lines, replies):
        assert reply.startswith(expect.get(line, "OK")), (line, reply)


def test_esair_send_against_the_pty():
    with emulator() as (_, path):
        run = subprocess.run(
            [sys.executable, "-m", "esair_min.cli", "send", path, "v", "t", "zz", "s"],
            cwd=ROOT, env=_env(), capture_output=True, timeout=60)
        assert run.stdout.decode().splitlines() == [
            VERSION, "OK", "E01 unknown command", "OK 512,512,512,512,512,512,512,512"]
        assert run.returncode == 1                  # one reply was an error
        run = subprocess.run(
            [sys.executable, "-m", "esair_min.cli", "send", path, "t", "--timeout", "3"],
            cwd=ROOT, env=_env(), capture_output=True, timeout=60)
        assert (run.returncode, run.stdout) == (0, b"OK\n")


def test_faults_over_the_pty():
    with emulator("--nack-actuator", "--corrupt-eeprom", "--no-sensor") as (_, path):
        with open_pty(path, 9600, timeout=3) as port:
            assert ask(port, "t") == "E10 no answer on i2c"
            assert ask(port, "PLY03") == "E09 motion image invalid"
            assert ask(port, "s") == "E10 no answer on i2c"
            assert ask(port, "v") == text(version(PAPAMAN, False, robot_id=INSTANCE))


def test_ctrl_c_exits_cleanly_and_the_port_reopens():
    with emulator(stop=signal.SIGINT) as (_, path):
        for _ in range(2):                      # clients come and go
            with open_pty(path, 9600, timeout=3) as port:
                assert ask(port, "v") == VERSION
