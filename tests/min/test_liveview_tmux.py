"""The live view as a user sees it: `esair emulate papaman --pty` in tmux, pane captured.

Each test runs its own tmux server (a private socket, no user config) with the
emulator in a window of a given size, drives the robot with `esair send` from another
process, captures the pane (`tmux capture-pane -p`, with `-S -` for what scrolled
away) and asserts on the captured text. The server is killed afterwards.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SERVOS = ["l_hip_yaw", "l_hip_roll", "l_hip_pitch", "l_knee", "l_ankle_pitch",
          "l_ankle_roll", "r_hip_yaw", "r_hip_roll", "r_hip_pitch", "r_knee",
          "r_ankle_pitch", "r_ankle_roll"]

pytestmark = [pytest.mark.skipif(shutil.which("tmux") is None,
                                reason="tmux missing: run scripts/install-toolchain.sh"), pytest.mark.pty]


class Tmux:
    def __init__(self, name: str):
        self.base = ["tmux", "-L", name, "-f", "/dev/null"]

    def __call__(self, *args: str) -> str:
        return subprocess.run(self.base + list(args), capture_output=True, text=True,
                              check=True, timeout=30).stdout

    def start(self, width: int, height: int, *args: str) -> None:
        cmd = " ".join([f"PYTHONPATH={ROOT}", sys.executable, "-m", "esair_min.cli",
                        "emulate", "papaman", "--pty", *args])
        self("new-session", "-d", "-s", "v", "-x", str(width), "-y", str(height),
             f"cd {ROOT} && exec env {cmd}")

    def screen(self, history: bool = False) -> str:
        return self("capture-pane", "-p", "-t", "v", *(["-S", "-"] if history else []))

    def wait(self, predicate, what: str, timeout: float = 90) -> str:
        deadline = time.monotonic() + timeout
        while True:
            text = self.screen()
            if predicate(text):
                return text
            if time.monotonic() > deadline:
                raise AssertionError(f"never on screen: {what}\n{text}")
            time.sleep(0.1)

    def port(self) -> str:
        text = self.wait(lambda t: re.search(r"/dev/pts/\d+", t), "the pty path")
        return re.search(r"/dev/pts/\d+", text).group(0)


@pytest.fixture
def tmux(request):
    name = f"esair-test-{os.getpid()}-{request.node.name[:40]}"
    t = Tmux(name)
    socket = Path(os.environ.get("TMUX_TMPDIR", "/tmp")) / f"tmux-{os.getuid()}" / name
    try:
        yield t
    finally:
        subprocess.run(t.base + ["kill-server"], capture_output=True, timeout=30)
        socket.unlink(missing_ok=True)          # the server leaves its socket file


def clean(text: str, width: int) -> bool:
    """One whole view drawn for ``width`` columns (not a copy made for another size)."""
    rows = text.splitlines()
    return (len(rows) > 2 and rows[0].startswith("papaman /dev/pts/") and "errors:" in text
            and text.count("papaman /dev/pts/") == 1 and all(len(r) <= width for r in rows)
            # the second servo column starts where a frame for this width puts it
            and rows[2].find("│ servo") == (width - 3) // 2 + 1)


def send(port: str, *lines: str) -> list[str]:
    run = subprocess.run([sys.executable, "-m", "esair_min.cli", "send", port, *lines],
                         cwd=ROOT, env=dict(os.environ, PYTHONPATH=str(ROOT)),
                         capture_output=True, text=True, timeout=60)
    return run.stdout.splitlines()


def pairs(screen: str) -> list[tuple[str, str]]:
    """(line, reply) of every row of the serial line on the screen."""
    return [(m.group(1), m.group(2).strip())
            for m in re.finditer(r"^  (\S+)\s+→ (.*)$", screen, re.M)]


def test_each_command_shows_its_own_reply_and_notices_are_marked(tmux):
    tmux.start(80, 24, "--scenario", "push")
    port = tmux.port()
    tmux.wait(lambda t: "notice !R auto_balance" in t, "the push's reaction notice")
    commands = ["v", "PLY03", "PLY01", "x"]
    replies = send(port, *commands)
    assert len(replies) == 4 and replies[0].startswith("OK esair-min/1")
    screen = tmux.wait(lambda t: ("x", "OK") in pairs(t), "the reply to x")
    shown = pairs(screen)[-4:]
    assert shown[1:] == list(zip(commands, replies))[1:]
    # the v reply (with the emulator's id=) is cut at the row's end
    assert shown[0][0] == "v" and replies[0].startswith(shown[0][1])
    assert shown[0][1].startswith("OK esair-min/1 servos=12 sensors=8 motions=5 image=ok")
    rows = screen.splitlines()
    notices = [r for r in rows if r.startswith("  notice ")]
    assert "  notice !R auto_balance" in notices
    assert all("→" not in r for r in notices)           # a notice answers no line
    assert all(len(r) <= 80 for r in rows) and len(rows) <= 24
    print("\n--- 80x24 ---\n" + screen)


def test_every_servo_legible_at_80x24_and_at_60x20(tmux):
    tmux.start(80, 24)
    screen = tmux.wait(lambda t: "r_ankle_roll" in t, "the servos")
    for name in SERVOS:
        assert re.search(rf"(^|│ ){name} +\d+ +\d+(\s|$)", screen, re.M), name
    tmux("resize-window", "-t", "v", "-x", "60", "-y", "20")
    screen = tmux.wait(lambda t: clean(t, 60) and "r_ankle_roll" in t,
                       "the view at 60 columns")
    for name in SERVOS:
        assert re.search(rf"(^|│ ){name} +\d+ +\d+(\s|$)", screen, re.M), name
    assert "serial line" in screen and "errors:" in screen
    print("\n--- 60x20 ---\n" + screen)


def test_no_stale_screen_after_resizing(tmux):
    tmux.start(60, 20, "--scenario", "push")
    port = tmux.port()
    send(port, "v", "t")
    tmux.wait(lambda t: ("t", "OK") in pairs(t), "the reply to t")
    for width, height in ((100, 30), (70, 22), (120, 40)):
        tmux("resize-window", "-t", "v", "-x", str(width), "-y", str(height))

        tmux.wait(lambda t, w=width: clean(t, w), f"one clean view at {width}x{height}")
    everything = tmux.screen(history=True)              # what scrolled away included
    assert clean(everything.rstrip("\n"), 120)          # nothing left of other sizes
    assert everything.count("papaman /dev/pts/") == 1, everything
    assert everything.count("serial line:") == 1
    assert len(re.findall(r"^servo ", everything, re.M)) == 1
    print("\n--- after resizing, history included ---\n" + everything)


def test_a_short_dance_is_visible_at_real_speed(tmux):
    tmux.start(80, 24)
    port = tmux.port()
    assert send(port, "PLY03") == ["OK"]                  # 0.29 s: about one redraw
    screen = tmux.wait(lambda t: "last: dance" in t, "the dance's summary")
    assert re.search(r"last: dance, 3[12] ticks \(0\.2[89] s\)", screen), screen
    row = next(ln for ln in screen.splitlines() if ln.startswith("l_hip_yaw"))
    history = row.split("│")[0].split()[-1]
    assert len(history) >= 15 and len(set(history)) >= 4, row   # the swing, tick by tick
    print("\n--- after a 0.29 s dance ---\n" + screen)
