"""The MIN link against `esair emulate --pty` in a child process: the robot pulled and
plugged back mid-motion, board faults and line noise on a real pty.

EmulatedRobot keeps a stable symbolic link to the emulator's current pty (as udev does
for a USB adapter); every test ends with no I/O thread and no child process left.
"""

from __future__ import annotations

import threading
import time
from pathlib import Path

import pytest

from esair_min.core.protocol import Code
from esair_min.model.validate import load_robot
from esair_std.drivers.minlink import Link, LinkDown, RobotRefused
from esair_std.drivers.minlink.emulated import EmulatedRobot
from esair_std.drivers.minlink.link import IDLE_LOOK_S, WIRE_CODES

pytestmark = pytest.mark.pty

ROOT = Path(__file__).resolve().parents[2]
PAPAMAN = ROOT / "boards" / "papaman"


@pytest.fixture(scope="module")
def robot():
    return load_robot(PAPAMAN)


def _wait(cond, seconds: float) -> bool:
    end = time.monotonic() + seconds
    while not cond() and time.monotonic() < end:
        time.sleep(0.01)
    return cond()


def _io_threads() -> list[str]:
    return [t.name for t in threading.enumerate() if t.name.startswith("minlink-io")]


def test_robot_pulled_mid_motion_and_plugged_back(tmp_path, robot):
    emu = EmulatedRobot(PAPAMAN, ["--trace", str(tmp_path / "t1.txt")])
    states: list[tuple[bool, str]] = []
    try:
        port = emu.start()
        link = Link(robot, port, on_state=lambda up, why: states.append((up, why)))
        link.open()
        try:
            link.play("dance")
            time.sleep(0.1)
            emu.kill()                                   # pulled while dancing
            assert _wait(lambda: not link.up, 15)
            with pytest.raises(LinkDown) as exc:         # at once: not sent, no timeout
                link.stand()
            assert str(exc.value).startswith(f"link to {port} is down (")
            assert str(exc.value).endswith("): 't' not sent")
            assert _wait(lambda: states, 15) and states[0][0] is False   # reported after .up drops
            # reconnect attempts fail while the robot is away
            assert _wait(lambda: "reconnecting: cannot open" in link.reason, 15), link.reason
            assert not link.up
            emu.start()                                  # plugged back (a new pty)
            assert _wait(lambda: link.up, 15)   # (the reconnect backoff: 2 s at most)
            assert states[-1] == (True, "up") and link.stats["reconnects"] == 1
            link.stand()
            link.motor("l_knee", 120, 3)
            assert link.feet()["groups"] == {"left_foot": 2048, "right_foot": 2048}
        finally:
            link.close()
    finally:
        emu.stop()
    assert not link.alive and _io_threads() == [] and emu.proc is None
    assert not Path(port).exists()


def test_a_command_in_flight_when_the_robot_goes(robot):
    with EmulatedRobot(PAPAMAN) as emu:
        with Link(robot, emu.port, timeout=2.0) as link:
            link.stand()
            killer = threading.Timer(0.05, emu.kill)
            killer.start()
            with pytest.raises(LinkDown) as exc:
                for _ in range(200):                     # one of these is in flight
                    link.feet()
            killer.join()
            text = str(exc.value)
            assert text.startswith(f"link to {emu.port} ")
            assert ("went down while 's' waited for its reply" in text
                    or text.endswith("'s' not sent")), text
    assert _io_threads() == []


def test_board_faults_and_noise_over_the_pty(robot):
    with EmulatedRobot(PAPAMAN, ["--nack-actuator", "--stuck-bus"]) as emu:
        with Link(robot, emu.port) as link:
            with pytest.raises(RobotRefused) as exc:
                link.motor("r_knee", 100)
            assert str(exc.value) == "robot refused 'ojc100': E10 no answer on i2c"
            with pytest.raises(RobotRefused, match=r"^robot refused 's': E10"):
                link.feet()
            assert link.up
    with EmulatedRobot(PAPAMAN, ["--noise", "15", "--seed", "3"]) as emu:
        with Link(robot, emu.port) as link:
            codes = []
            for line in ["v", "s", "x"] * 10:
                try:
                    data = link.command(line)
                    assert data.startswith("esair-min/1") if line == "v" else True
                    assert len(data.split(",")) == 8 if line == "s" else True
                except RobotRefused as exc:
                    assert exc.command == line
                    codes.append(exc.code)
            assert codes and set(codes) <= WIRE_CODES, codes
            assert Code.NO_ANSWER not in codes
    assert _io_threads() == []


def test_an_idle_link_sleeps_until_it_has_something_to_do(robot):
    """With nothing in flight the I/O thread waits in select on the port (and its wake
    pipe) for at most IDLE_LOOK_S at a time: over a quiet spell it wakes at most once per
    IDLE_LOOK_S (a starved thread wakes less, never more), not once per short read
    timeout; and a line it reads is counted once, whole, however its bytes came."""
    with EmulatedRobot(PAPAMAN) as emu, Link(robot, emu.port) as link:
        assert link.version().startswith("esair-min")
        before, t0 = link.stats["wakes"], time.monotonic()
        time.sleep(2.0)                          # the quiet spell being measured
        woke, spell = link.stats["wakes"] - before, time.monotonic() - t0
        assert woke <= spell / IDLE_LOOK_S + 1, (woke, spell)
        assert link.version().startswith("esair-min")      # and it still answers at once
        assert link.stats["timeouts"] == 0
