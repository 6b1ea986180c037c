"""PAPA-MAN under STD, end to end, in every mode: the runtime -> the MinLink driver ->
a pty -> `esair emulate` (central, actuator and sensor boards on the virtual I2C bus)
-> the actuator board's registers, asserted on the emulator's trace.

The emulated robot is a child process at a stable port (EmulatedRobot), so a test can
pull it and plug it back; its trace is read after it stopped.
"""

from __future__ import annotations

import threading
import time
from pathlib import Path

import pytest
import yaml

from tests.support.std import emulators_with, wait_for
from esair_min.core.trace import without_marks
from esair_min.emulator.papaman.actuator import encode
from esair_min.model.validate import load_robot
from esair_std.drivers.minlink.emulated import EmulatedRobot

pytestmark = pytest.mark.pty

ROOT = Path(__file__).resolve().parents[2]
PAPAMAN = ROOT / "boards" / "papaman"
EXAMPLE = ROOT / "esair_std" / "examples" / "papaman" / "papaman.yaml"
ACTUATOR = 0x10


@pytest.fixture(scope="module")
def robot():
    return load_robot(PAPAMAN)


@pytest.fixture
def emulated(tmp_path):
    """emulated(*args) -> a running EmulatedRobot with --trace; stopped after the test."""
    made = []

    def _start(*args):
        emu = EmulatedRobot(PAPAMAN, ["--trace", str(tmp_path / f"trace{len(made)}.txt"),
                                      *args])
        made.append(emu)
        emu.start()
        emu.trace = tmp_path / f"trace{len(made) - 1}.txt"
        return emu

    yield _start
    for emu in made:
        emu.stop()


def example(port: str, **extra) -> dict:
    """The bundled example deployment, pointed at ``port``."""
    dep = yaml.safe_load(EXAMPLE.read_text())
    dep["resources"]["papaman"]["port"] = port
    if port != "emulate":
        dep["resources"]["papaman"].pop("emulate", None)
    for entry in dep["behaviors"].values():
        entry["class"] = "esair_std.examples.papaman." + entry["class"]
    dep["behaviors"].update(extra)
    dep["resources"]["papaman"]["allow"].update({name: "command" for name in extra})
    return dep


def actuator_writes(trace: Path | list[str]) -> list[tuple[int, bytes]]:
    """(tick, bytes) of every acknowledged write to the actuator board, in order."""
    tick, out = 0, []
    lines = trace if isinstance(trace, list) else trace.read_text().splitlines()
    for line in without_marks(lines):
        if line.startswith("T "):
            tick = int(line[2:])
        elif line.startswith(f"W {ACTUATOR:02X} ") and line.endswith(" ACK"):
            out.append((tick, bytes.fromhex(line.split()[2])))
    return out


def test_servo_commands_arrive_in_order_within_limits(start, emulated, robot):
    emu = emulated()
    moves = [["l_knee", 120, 3], ["r_hip_pitch", 30, 0], ["l_knee", 151, 2],  # > 150
             ["l_ankle_roll", 60, 5], ["r_knee", 29, 1], ["l_knee", 0, 25]]    # < 30
    rt = start(example(emu.port, mover={"class": "tests.support.papaman_comps:Mover", "moves": moves,
                                        "uses": {"papaman.servo.*": "command"}}))
    rt.wait_state("mover", "running")
    got = wait_for(lambda: (r := rt.get("mover"))["results"] and len(r["results"]) == 6 and r,
                   what="six moves")
    rt.stop()
    emu.stop()
    assert [r[0] for r in got["results"]] == ["ok", "ok", "CommandError", "ok",
                                             "CommandError", "ok"]
    assert got["results"][1][1] == "oia030"
    assert got["results"][2][1] == (
        f"papaman.servo.l_knee: servo l_knee: angle 151 is outside its limits 0..150 "
        f"({PAPAMAN / 'actuator.yaml'}); not sent")
    servos = {s.name: s for s in robot.servos}
    sent = [m for m in moves if servos[m[0]].min_angle <= m[1] <= servos[m[0]].max_angle]
    two_reg = [(w[0], w[1:]) for _, w in actuator_writes(emu.trace) if len(w) == 3]
    assert two_reg == [(2 * servos[s].index, bytes(encode(a, v))) for s, a, v in sent]


def test_a_put_starts_the_dance(start, emulated, robot):
    emu = emulated()
    rt = start(example(emu.port))
    rt.wait_state("sequencer", "running")
    rt.wait_state("papaman.motion", "ready", timeout=30)   # else the dance is dropped
    rt.put("sequencer", ["dance"], timeout=2.0)
    wait_for(lambda: rt.get("sequencer")["done"] == ["dance"], timeout=30,
             what=lambda: f"the dance played: {rt.get('sequencer')}")
    dance = robot.motion("dance")
    frames = [b"\x00" + b"".join(bytes(encode(a, f.speeds()[i])) for i, a in enumerate(f.angles))
              for f in dance.frames]
    # "done" is the sequencer's host-clock estimate: the robot's trace says when it played
    wait_for(lambda: sum(len(w) == 25 for _, w in actuator_writes(emu.trace)) >= len(frames),
             what="the dance's frames in the trace")
    rt.stop()
    emu.stop()
    writes = [(t, w) for t, w in actuator_writes(emu.trace) if len(w) == 25]
    assert [w for _, w in writes] == frames                       # every frame, in order
    ticks = [t for t, _ in writes]
    assert ticks == list(range(ticks[0], ticks[0] + len(frames)))  # one per tick


def test_the_push_reaches_the_watcher_and_its_stop_the_robot(start, emulated, robot):
    # the bundled push scenario, held until the deployment is up (a process-mode deploy
    # takes seconds on a busy machine): played (SIGUSR1) once the watcher runs and the
    # feet's samples reach it, so its clock starts at readiness, not at the emulator's boot
    emu = emulated("--scenario", "push", "--hold-scenario")
    rt = start(example(emu.port))
    rt.wait_state("watcher", "running")
    wait_for(lambda: rt.get("watcher")["samples"] >= 2, timeout=30, what="the feet's samples")
    # the tip lasts 400 ms of the robot's clock: a host starved for that long may poll it
    # once only (the firmware's own reaction is the one that cannot miss it), and the
    # reaction's stand, tried while the firmware's balance motion plays (E07), is dropped
    # after STAND_RETRY_S: the push is played again, 5 s apart, until a reaction has sent
    # its stop and its stand. The firmware's `!R` notice comes on its own sensor, in no
    # set order with the reaction's commands: both waited for
    plays: list[float] = []
    seen: dict = {}

    def stood():
        w = seen["w"] = rt.get("watcher")
        done = [r for r in w["reactions"] if r["sent"] == ["x", "t"]]
        if done and w["firmware_reactions"] >= 1:
            return w, done[0]
        if not done and (not plays or time.monotonic() - plays[-1] > 5.0):
            emu.play_scenario()
            plays.append(time.monotonic())
        return None
    got, reaction = wait_for(stood, timeout=70, what=lambda: (
        f"a reaction that sent its stop and its stand, and the firmware's notice ({len(plays)} "
        f"pushes played; the watcher: {seen.get('w')})"))
    rt.stop()
    emu.stop()
    assert reaction["shift"] == 1360 and reaction["sent"] == ["x", "t"], got
    # in the trace: the firmware's own reaction (its notice), then the host's stand pose
    # (every servo to its stand angle at its default speed), written after the tilt began
    # (the tick of the firmware's first read of the tipping feet: 680 left, 340 right)
    stand = b"\x00" + b"".join(bytes(encode(s.stand_angle, s.default_speed))
                               for s in robot.servos)
    lines = without_marks(emu.trace.read_text().splitlines())
    tipping = (680).to_bytes(2, "little").hex().upper() * 4 + (340).to_bytes(2, "little").hex().upper() * 4
    onset = sensor_read_ticks(lines, robot.peer("sensor").address, tipping)[0]
    assert "TX " + b"!R auto_balance\r\n".hex().upper() in lines
    assert any(t >= onset and w == stand for t, w in actuator_writes(emu.trace))
    assert got["firmware_reactions"] >= 1


def sensor_read_ticks(lines: list[str], address: int, readings: str) -> list[int]:
    """Ticks at which the central board read ``readings`` (hex) from the sensor board at
    ``address``."""
    tick, out = 0, []
    for line in lines:
        if line.startswith("T "):
            tick = int(line[2:])
        elif line.startswith(f"R {address:02X} ") and line.endswith(" " + readings):
            out.append(tick)
    return out


def test_resources_are_lost_while_the_robot_is_pulled(start, emulated):
    emu = emulated()
    rt = start(example(emu.port, mover={"class": "tests.support.papaman_comps:Mover", "moves": [],
                                        "uses": {"papaman.servo.*": "command"}}))
    rt.put("mover", {"servo": "l_knee", "angle": 100}, timeout=2.0)
    wait_for(lambda: rt.get("mover")["results"] == [["ok", "odc100"]], what="first move")
    emu.kill()
    rows = wait_for(lambda: len(lost := [r for r in rt.ls() if r["name"].startswith(
        "papaman.") and r["state"] == "lost"]) == 15 and lost, what="resources lost")
    names = {r["name"] for r in rows}
    assert {"papaman.motion", "papaman.feet", "papaman.notices", "papaman.servo.l_knee"} <= names
    assert all(r["reason"].startswith("link down: ") for r in rows)
    rt.put("mover", {"servo": "l_knee", "angle": 110}, timeout=2.0)
    res = wait_for(lambda: len((r := rt.get("mover"))["results"]) == 2 and r, what="2nd move")
    kind, text = res["results"][1]
    assert kind == "ResourceLost" and text.startswith("papaman.servo.l_knee: lost: link down: ")
    assert res["states"]["papaman.servo.l_knee"] == "lost"
    emu.start()                                             # plugged back
    wait_for(lambda: all(r["state"] == "ready" for r in rt.ls()
                         if r["name"].startswith("papaman.")), what="resources ready")
    rt.put("mover", {"servo": "l_knee", "angle": 120}, timeout=2.0)
    res = wait_for(lambda: len((r := rt.get("mover"))["results"]) == 3 and r, what="3rd move")
    assert res["results"][2] == ["ok", "odc120"]


def test_board_faults_surface_on_the_right_resource(start, emulated):
    emu = emulated("--nack-actuator")
    rt = start(example(emu.port, mover={"class": "tests.support.papaman_comps:Mover", "moves": [],
                                        "uses": {"papaman.servo.*": "command"}}))
    rt.put("mover", {"servo": "l_knee", "angle": 100}, timeout=2.0)
    got = wait_for(lambda: (r := rt.get("mover"))["results"] and r, what="the move")
    assert got["results"] == [["CommandError", "papaman.servo.l_knee: robot refused "
                                               "'odc100': E10 no answer on i2c"]]
    assert rt.state("papaman.feet") == "ready"            # the sensor board answers
    rt.stop()
    emu.stop()
    emu = emulated("--stuck-bus")
    rt = start(example(emu.port))
    row = wait_for(lambda: [r for r in rt.ls() if r["name"] == "papaman.feet"
                            and r["state"] == "lost"], what="feet lost")[0]
    assert row["reason"] == "robot refused 's': E10 no answer on i2c"
    assert rt.state("papaman.motion") == "ready"           # the link itself is up


def test_the_example_runs_its_own_emulated_robot(start, tmp_path):
    trace = tmp_path / "own.txt"
    dep = example("emulate")
    dep["resources"]["papaman"]["emulate"]["trace"] = str(trace)
    rt = start(dep)
    assert len(emulators_with(str(trace))) == 1          # `esair emulate ... --trace`
    rt.wait_state("sequencer", "running")
    # the sequencer drops what is queued while the link is not ready: asked once it is
    rt.wait_state("papaman.motion", "ready", timeout=30)
    rt.put("sequencer", ["stand_up", "dance"], timeout=2.0)
    wait_for(lambda: rt.get("sequencer")["done"] == ["stand_up", "dance"], timeout=30,
             what=lambda: f"two ops: {rt.get('sequencer')}")
    logged = wait_for(lambda: (g := rt.get("logger"))["records"] and g, what="a record")
    assert set(logged["records"][-1]) == {"t", "sequencer", "watcher"}

    def frames() -> list[bytes]:
        return [w for _, w in actuator_writes(trace) if len(w) == 25]
    # "done" is the sequencer's host-clock estimate; a starved emulator may still be
    # writing the dance's last frames: wait for the robot's own trace to show them
    wait_for(lambda: len(frames()) >= 1 + 32, what="the dance's frames in the trace")
    rt.stop()
    assert emulators_with(str(trace)) == []               # the child is gone
    assert not [t for t in threading.enumerate() if t.name.startswith("minlink")]
    assert len(frames()) == 1 + 32                         # stand's frame, the dance's 32
