"""The same end-to-end path with the host-built C firmware behind the pty instead of
the Python emulator: runtime -> MinLink -> pty -> generated C core (gcc -Werror, the
host port's device models) -> its trace. See c_robot.py for what is (not) modelled."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from tests.support.c_robot import CFirmwareRobot
from esair_min.codegen import generate_robot
from tests.support.std import wait_for
from esair_min.emulator.papaman.actuator import encode
from tests.std.test_std_papaman import actuator_writes, example

pytestmark = pytest.mark.pty


@pytest.fixture(scope="module")
def firmware(robot, tmp_path_factory):
    out = tmp_path_factory.mktemp("cgen")
    generate_robot(robot, out)
    proc = subprocess.run(["make", "-s", "host", "HOST_BIN=firmware_host"],
                          cwd=out / "central", capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return out / "central" / "firmware_host"


@pytest.fixture(scope="module")
def robot():
    from esair_min.model.validate import load_robot
    return load_robot(Path(__file__).resolve().parents[2] / "boards" / "papaman")


def test_std_drives_the_c_firmware(start, firmware, robot):
    c = CFirmwareRobot(firmware, robot.central.timer2.period_s)
    port = c.start()
    try:
        moves = [["l_knee", 120, 3], ["l_knee", 151, 2], ["r_ankle_roll", 61, 0]]
        rt = start(example(port, mover={"class": "tests.support.papaman_comps:Mover", "moves": moves,
                                        "uses": {"papaman.servo.*": "command"}}))
        got = wait_for(lambda: len((r := rt.get("mover"))["results"]) == 3 and r,
                       what="three moves")
        assert [r[0] for r in got["results"]] == ["ok", "CommandError", "ok"]
        rt.put("sequencer", ["dance"], timeout=2.0)
        wait_for(lambda: rt.get("sequencer")["done"] == ["dance"], what="the dance")
        # "done" is the sequencer's host-clock estimate: the firmware's trace says when
        wait_for(lambda: sum(len(w) == 25 for _, w in actuator_writes(list(c.lines)))
                 >= len(robot.motion("dance").frames), what="the dance's frames in the trace")
        rt.stop()
    finally:
        lines = c.stop()
    servos = {s.name: s for s in robot.servos}
    writes = actuator_writes(lines)
    assert [(w[0], w[1:]) for _, w in writes if len(w) == 3] == [
        (2 * servos["l_knee"].index, bytes(encode(120, 3))),
        (2 * servos["r_ankle_roll"].index, bytes(encode(61, 0)))]
    dance = robot.motion("dance")
    frames = [b"\x00" + b"".join(bytes(encode(a, f.speeds()[i])) for i, a in enumerate(f.angles))
              for f in dance.frames]
    played = [(t, w) for t, w in writes if len(w) == 25]
    assert [w for _, w in played] == frames
    ticks = [t for t, _ in played]
    assert ticks == list(range(ticks[0], ticks[0] + len(frames)))
