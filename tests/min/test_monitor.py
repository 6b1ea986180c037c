"""``esair monitor`` as a person uses it (issue 32 item 3): in a terminal (tmux), typing
commands, recalling one from the history, Ctrl-C. The board is a pty whose other end the
test holds (every byte the monitor sends is seen) or an esair:// emulator."""

from __future__ import annotations

import os
import re
import select
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
STAMP = r"\d\d:\d\d:\d\d\.\d\d\d"

pytestmark = pytest.mark.skipif(shutil.which("tmux") is None,
                                reason="tmux missing: run scripts/install-toolchain.sh")


class Term:
    """``esair monitor ARGS`` in a tmux window of its own server; its status printed when
    it ends."""

    def __init__(self, name: str, tmp: Path, *args: str) -> None:
        self.base = ["tmux", "-L", name, "-f", "/dev/null"]
        cmd = " ".join([sys.executable, "-m", "esair_min.cli", "monitor", *args])
        env = f"PYTHONPATH={ROOT} XDG_STATE_HOME={tmp}"
        self("new-session", "-d", "-s", "m", "-x", "160", "-y", "40",
             f"cd {tmp} && env {env} {cmd}; echo status=$?; sleep 600")

    def __call__(self, *args: str) -> str:
        return subprocess.run(self.base + list(args), capture_output=True, text=True,
                              check=True, timeout=30).stdout

    def keys(self, *keys: str) -> None:
        self("send-keys", "-t", "m", *keys)

    def wait(self, pattern: str, timeout: float = 30) -> str:
        deadline = time.monotonic() + timeout
        while True:
            text = self("capture-pane", "-p", "-t", "m", "-S", "-")
            if re.search(pattern, text, re.M):
                return text
            if time.monotonic() > deadline:
                raise AssertionError(f"never on screen: {pattern}\n{text}")
            time.sleep(0.1)

    def kill(self) -> None:
        subprocess.run(self.base + ["kill-server"], capture_output=True, timeout=30)


def board_reads(master: int, timeout: float) -> bytes:
    """What the monitor sent to the board within ``timeout`` s."""
    out = b""
    deadline = time.monotonic() + timeout
    while (left := deadline - time.monotonic()) > 0:
        if select.select([master], [], [], left)[0]:
            out += os.read(master, 256)
    return out


def test_monitor_in_a_terminal_on_a_pty(tmp_path):
    master, slave = os.openpty()
    name = os.ttyname(slave)
    log = tmp_path / "board.log"
    term = Term(f"esair-mon-{os.getpid()}", tmp_path, name, "--robot", "papaman",
                "--log", str(log))
    try:
        term.wait("monitoring .* type a command")
        os.write(master, b"!READY esair-min/1 image=ok\r\n!R auto_balance\r\n")
        screen = term.wait("reaction auto_balance")
        assert re.search(STAMP + r" < !READY esair-min/1 image=ok +\[board reset and ready: "
                         r"protocol esair-min/1, motion image ok \(monitoring papaman\)\]", screen)
        assert re.search(STAMP + r" < !R auto_balance +\[reaction auto_balance fired: "
                         r"plays motion \w+\]", screen)
        assert board_reads(master, 1.0) == b""           # nothing sent untyped
        term.keys("PLY99", "Enter")
        assert board_reads(master, 5.0) == b"PLY99\r\n"
        os.write(master, b"E08 no such motion\r\n")
        term.wait(STAMP + r" < E08 no such motion +\[E08: no motion of that number\]")
        term.keys("Up", "Enter")                          # the history
        assert board_reads(master, 5.0) == b"PLY99\r\n"
        os.write(master, b"!E10 no answer on i2c\r\n")
        term.wait(r"\[notice: E10: a board or the EEPROM did not acknowledge on I2C\]")
        term.keys("C-c")
        screen = term.wait("status=")
        assert "monitor stopped: 4 lines received" in screen and "status=130" in screen
        assert "Traceback" not in screen
        assert board_reads(master, 0.5) == b""
        text = log.read_text()
        assert re.search(STAMP + r" > PLY99\n", text) and "< !R auto_balance" in text
    finally:
        term.kill()
        os.close(master)
        os.close(slave)


def test_monitor_an_emulated_robot_through_its_url(tmp_path):
    term = Term(f"esair-mon-url-{os.getpid()}", tmp_path, "'esair://papaman?speed=max'")
    try:
        term.wait("monitoring esair://")
        term.keys("v", "Enter")
        term.wait(STAMP + r" < OK esair-min/1 servos=12")
        term.keys("C-c")
        assert "status=130" in term.wait("status=")
    finally:
        term.kill()


def test_send_with_no_commands_points_to_monitor():
    r = subprocess.run([sys.executable, "-m", "esair_min.cli", "send", "/dev/ttyUSB3"],
                       capture_output=True, text=True, timeout=60,
                       env=dict(os.environ, PYTHONPATH=str(ROOT)))
    assert r.returncode == 2
    assert "use: esair monitor /dev/ttyUSB3" in r.stderr
