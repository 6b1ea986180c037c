"""The emulator's pty keeps its promise (docs/emulator.md; issue 19 item 6): the boot
notice is never visible, not even to a program that opens the port the instant the
path is printed, and a program's read never raises; a stopped robot (SIGSTOP) does not
play, when it runs again, what it was sent meanwhile.
"""

from __future__ import annotations

import pytest

import os
import signal
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import serial
from tests.support.board_lines import PAPAMAN, version
from tests.support.robot_ptys import open_pty

pytestmark = pytest.mark.pty

ROOT = Path(__file__).resolve().parents[2]
VERSION = version(PAPAMAN, robot_id="0123abcd")
TRIALS = 40


def _served(*args: str) -> tuple[subprocess.Popen, str]:
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.Popen([sys.executable, "-m", "esair_min.cli", "emulate", "papaman",
                             "--pty", "--instance", "0123abcd", *args], cwd=ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    return proc, proc.stdout.readline().decode().strip()


def _end(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
    proc.wait(timeout=30)
    proc.stdout.close()
    proc.stderr.close()


def _first_opener() -> tuple[bytes, bytes]:
    """Open the port the instant its path is printed; what it reads unasked, then the
    answer to v."""
    proc, path = _served()
    try:
        with open_pty(path, 9600, timeout=0.5) as port:
            unasked = port.read(100)
            port.timeout = 10            # the answer may come late on a loaded machine
            port.write(b"v\r\n")
            return unasked, port.readline()
    finally:
        _end(proc)


def test_the_first_opener_never_reads_the_boot_notice_and_never_raises():
    with ThreadPoolExecutor(max_workers=8) as pool:
        outcomes = list(pool.map(lambda _: _first_opener(), range(TRIALS)))
    assert outcomes == [(b"", VERSION)] * TRIALS


def test_forty_openers_at_once_read_nothing_old_and_never_raise():
    proc, path = _served()
    got: list[bytes | str] = []
    lock = threading.Lock()
    start = threading.Barrier(TRIALS)

    def opener() -> None:
        try:
            start.wait(30)
            # unlocked: forty programs at once, as no ESAIR program would open it
            with serial.Serial(path, 9600, timeout=0.3) as port:
                data = port.read(100)
        except Exception as exc:  # noqa: BLE001 - what a program would see
            data = f"{type(exc).__name__}: {exc}"
        with lock:
            got.append(data)
    try:
        threads = [threading.Thread(target=opener) for _ in range(TRIALS)]
        for t in threads:
            t.start()
        for t in threads:
            t.join(60)
        with open_pty(path, 9600, timeout=2) as port:    # the robot still answers
            port.write(b"v\r\n")
            assert port.readline() == VERSION
    finally:
        _end(proc)
    assert got == [b""] * TRIALS


def _state(pid: int) -> str:
    with open(f"/proc/{pid}/stat") as f:
        return f.read().rsplit(")", 1)[1].split()[0]


def test_a_stopped_robot_drops_what_it_was_sent_meanwhile(tmp_path):
    trace = tmp_path / "t.txt"
    proc, path = _served("--trace", str(trace))
    try:
        with open_pty(path, 9600, timeout=0.5) as port:
            os.kill(proc.pid, signal.SIGSTOP)
            try:
                while _state(proc.pid) != "T":  # stopped (the signal is asynchronous)
                    time.sleep(0.01)
                port.write(b"PLY03\r\n")
                time.sleep(1.5)                 # more than the 1 s pause of a powerless robot
            finally:
                os.kill(proc.pid, signal.SIGCONT)
            got = b""
            for _ in range(20):                 # v until the robot, running again, answers
                port.write(b"v\r\n")
                got += port.read_until(VERSION)
                if got.endswith(VERSION):
                    break
            assert got.endswith(VERSION)
            assert b"OK\r\n" not in got       # the dance's OK never came: not played
    finally:
        _end(proc)
    text = trace.read_text()
    assert "TX " + b"OK\r\n".hex().upper() not in text.splitlines()
    assert not [line for line in text.splitlines() if line.startswith("W 10 ")]
