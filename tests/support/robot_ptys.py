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
from typing import Any

from esair_min.core.trace import without_marks
from esair_min.serialport import open_port
from tests.support.board_lines import PAPAMAN, version

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


#: `esair emulate` run up to the moment it opens its pty, where it waits for a byte on
#: stdin: from that byte to its pty is one system call, not a start-up (another
#: program of a busy machine opening a pty meanwhile would take the number).
_PRELOADED = ("import os, sys\n"
              "_openpty = os.openpty\n"
              "def _when_told():\n"
              "    sys.stderr.write('ready\\n'); sys.stderr.flush()\n"
              "    sys.stdin.buffer.read(1)\n"
              "    return _openpty()\n"
              "os.openpty = _when_told\n"
              "from esair_min.cli import main\n"
              "main(sys.argv[1:])\n")


def start_on_number(number: int, *args: str) -> tuple[subprocess.Popen, str]:
    """Start `esair emulate papaman --pty ARGS` so that it gets /dev/pts/``number``, as
    the next program opening a pty does once that number is free: every lower free
    number, and ``number`` itself, is held here until the emulator is about to open its
    pty (the kernel hands out the lowest free number). Another program of this shared
    machine may take the number first: then it is tried again."""
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    for _ in range(5):
        proc = subprocess.Popen([sys.executable, "-c", _PRELOADED, "emulate", "papaman",
                                 "--pty", *args], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, env=env, cwd=ROOT)
        assert proc.stderr.readline() == b"ready\n"
        held = _hold_up_to(number)
        path = ""
        try:
            if held:
                for fd in held.pop():            # ``number`` itself: free it now, then go
                    os.close(fd)
                proc.stdin.write(b"x")
                proc.stdin.flush()
                path = proc.stdout.readline().decode().strip()
        finally:
            for master, slave in held or ():
                os.close(master)
                os.close(slave)
        if path == f"/dev/pts/{number}":
            return proc, path
        proc.kill()              # not told to go, it waits in its read: a SIGTERM it handles
        stop(proc)
    raise AssertionError(f"/dev/pts/{number} went to other programs five times")


def _hold_up_to(number: int, seconds: float = 20.0) -> list[tuple[int, int]] | None:
    """Open ptys until the kernel gives ``number``: every pair opened up to it (it last);
    None if it did not come free in ``seconds`` (another program holds it)."""
    held: list[tuple[int, int]] = []
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        master, slave = os.openpty()
        got = int(os.ttyname(slave).rsplit("/", 1)[1])
        if got <= number:
            held.append((master, slave))
            if got == number:
                return held
            continue
        os.close(master)                         # not free yet (released in the background)
        os.close(slave)
        time.sleep(0.02)
    for master, slave in held:
        os.close(master)
        os.close(slave)
    return None


#: PAPA-MAN's `v` reply up to its id.
VERSION = version(PAPAMAN, robot_id="")[:-2]


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
    for f in (proc.stdin, proc.stdout, proc.stderr):
        if f is not None:
            f.close()


def open_pty(path: str, baudrate: int = 9600, **settings: Any) -> Any:
    """A test's end of a robot's pty, opened as ESAIR's own programs open a port: locked
    (esair_min.serialport). A runtime of another test whose link reconnects to a reused
    pty number is then refused instead of reading half of this test's replies; one that
    got there first holds the lock only for its probe, so this waits up to 10 s for it."""
    return open_port(path, lock_wait=10.0, baudrate=baudrate, **settings)
