"""Ptys and traces of emulated robots, for the tests of the robot's identity and of stale
motions (issue 19): which /dev/pts number an emulator serves, another emulator started
on that very number, what a robot answered and played (from its --trace)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from esair_min.core.trace import without_marks

ROOT = Path(__file__).resolve().parents[2]


def pty_number(pid: int) -> int:
    """The /dev/pts number of the pty an `esair emulate --pty` process serves (the
    tty-index of its /dev/ptmx descriptor)."""
    for fd in os.listdir(f"/proc/{pid}/fd"):
        try:
            if os.readlink(f"/proc/{pid}/fd/{fd}") != "/dev/ptmx":
                continue
            with open(f"/proc/{pid}/fdinfo/{fd}") as f:
                for line in f:
                    if line.startswith("tty-index:"):
                        return int(line.split()[1])
        except OSError:
            continue
    raise AssertionError(f"process {pid} holds no pty master")


def start_on_number(number: int, *args: str) -> tuple[subprocess.Popen, str]:
    """Start `esair emulate papaman --pty ARGS` so that it gets /dev/pts/``number``, as
    the next program opening a pty does once that number is free: every lower free
    number is held here meanwhile (the kernel hands out the lowest free one). Another
    program of this shared machine may take the number first: then it is tried again."""
    for _ in range(5):
        proc, path = _start_after(number, args)
        if path == f"/dev/pts/{number}":
            return proc, path
        stop(proc)
    raise AssertionError(f"/dev/pts/{number} went to other programs five times")


def _start_after(number: int, args: tuple[str, ...]) -> tuple[subprocess.Popen, str]:
    held: list[tuple[int, int]] = []
    end = time.monotonic() + 20
    try:
        while True:
            master, slave = os.openpty()
            got = int(os.ttyname(slave).rsplit("/", 1)[1])
            if got == number:
                os.close(master)
                os.close(slave)
                break
            if got < number:
                held.append((master, slave))
                continue
            os.close(master)                     # not free yet (released in the background)
            os.close(slave)
            assert time.monotonic() < end, f"/dev/pts/{number} never came free"
            time.sleep(0.05)
        env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
        proc = subprocess.Popen([sys.executable, "-m", "esair_min.cli", "emulate", "papaman",
                                 "--pty", *args], stdout=subprocess.PIPE,
                                stderr=subprocess.DEVNULL, env=env, cwd=ROOT)
        path = proc.stdout.readline().decode().strip()
    finally:
        for master, slave in held:
            os.close(master)
            os.close(slave)
    return proc, path


def replies(trace: Path) -> list[bytes]:
    """Every line the emulated robot sent, from its trace."""
    return [bytes.fromhex(line[3:]) for line in without_marks(trace.read_text().splitlines())
            if line.startswith("TX ")]


def frames(trace: Path) -> int:
    """How many whole-robot frames (12 servos: 25 bytes) went to the actuator board."""
    return sum(1 for line in without_marks(trace.read_text().splitlines())
               if line.startswith("W 10 ") and line.endswith(" ACK")
               and len(bytes.fromhex(line.split()[2])) == 25)


def stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
    proc.wait(timeout=10)
    proc.stdout.close()
