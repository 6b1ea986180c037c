"""The latched STOP (issue 34 item 1; docs/std.md, "The latched stop"), judged by the
robot's own trace: the emulated PAPA-MAN writes every line it received (``--trace-rx``)
and every write to its actuator board, so "no servo moved after the STOP" is read where
the servos are, not from the host's word.

Ten dances are queued (the CLI's STOP takes an interpreter's start to come), the one
playing is cut by the STOP; then, until the release, no
actuator write and no motion line reaches the robot, every behavior's command is
refused with the STOP's words, and nothing queued plays after the release, while the
nudger's next command moves the robot again. Both modes; the STOP by the Python API
and by ``esair std stop``.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from esair_std.drivers.minlink.emulated import EmulatedRobot
from esair_std.errors import ControlError, Refused
from tests.std.test_std_papaman import example
from tests.support.scenarios import push_soon
from tests.support.std import esair, wait_for

ROOT = Path(__file__).resolve().parents[2]
PAPAMAN = ROOT / "boards" / "papaman"
REFUSAL = re.compile(r"papaman\.servo\.l_knee: stopped by (\S+) at \d\d:\d\d:\d\d: "
                     r"release with esair std release")
STOP_LINE = "RX 780D"             # x CR, as the robot's decoder took it (docs/trace-format.md)
HOLD_LINE = "RX 68310D"           # h1 CR: the firmware's reactions held (docs/protocol.md)
RELEASE_LINE = "RX 68300D"        # h0 CR: released
DANCES = 10
DANCE_FRAMES = 32                   # boards/papaman/central.yaml
QUIET = {"RX 0D", STOP_LINE, HOLD_LINE, "RX 730D", "RX 760D"}   # resync, x, h1, s, v


def nudger() -> dict:
    return {"nudger": {"class": "tests.support.papaman_comps:Nudger",
                       "uses": {"papaman.servo.*": "command"}}}


def frames(lines: list[str]) -> list[int]:
    """Indexes of the dance's frame writes (all 12 servos: 25 bytes to the actuator)."""
    return [i for i, line in enumerate(lines)
            if line.startswith("W 10 ") and len(line.split()[2]) == 50 and line.endswith("ACK")]


def after_stop(lines: list[str]) -> tuple[int, list[str]]:
    """The index of the robot's first ``x`` after the dance began, and the actuator
    writes and moving lines it got after that."""
    first = frames(lines)[0]
    at = next(i for i in range(first, len(lines)) if lines[i] == STOP_LINE)
    moved = [line for line in lines[at + 1:]
             if (line.startswith("W 10 ") and line.endswith(" ACK"))
             or (line.startswith("RX ") and line not in QUIET)]
    return at, moved


def outcomes(rt) -> list[list[str]]:
    return rt.get("nudger", timeout=5.0)["outcomes"]


def stop(how: str, rt) -> str:
    """STOP the robot ``how``; who the runtime says stopped it."""
    if how == "api":
        return rt.stop_robot("the test")["by"]
    r = esair("stop", "--reason", "the test", "-e", rt.endpoint)
    assert r.stdout.startswith("STOPPED by operator at "), r.stdout
    assert r.stdout.rstrip().endswith("(the test): release with esair std release")
    return "operator"


def release(how: str, rt) -> None:
    if how == "api":
        rt.release_robot()
    else:
        r = esair("release", "-e", rt.endpoint)
        assert r.stdout.startswith("released (stopped by operator at "), r.stdout


@pytest.mark.parametrize("how", ["api", "cli"])
def test_a_stop_latches_until_released(start, tmp_path, how):
    trace = tmp_path / "trace.txt"
    emu = EmulatedRobot(PAPAMAN, ["--trace", str(trace), "--trace-rx"])
    emu.start()
    try:
        rt = start(example(emu.port, **nudger()), control=True)
        rt.wait_state("nudger", "running")
        rt.wait_state("sequencer", "running")
        rt.put("sequencer", ["dance"] * DANCES, timeout=2.0)
        wait_for(lambda: len(frames(trace.read_text().splitlines())) >= 3, timeout=20,
                 what="the first dance playing")
        by = stop(how, rt)
        assert rt.latched is not None and rt.latched["by"] == by
        n = len(outcomes(rt))
        # the nudger's next commands: each refused with the STOP's words
        got = wait_for(lambda: len(o := outcomes(rt)[n:]) >= 4 and o, timeout=20,
                       what="the nudger's commands while STOPPED")
        assert all(kind == "CommandError" and REFUSAL.fullmatch(text) for kind, text in got), got
        assert {REFUSAL.fullmatch(text).group(1) for _, text in got} == {by}
        seq = rt.get("sequencer")
        # the one playing cut (if one played), the others dropped (each reported)
        assert seq["queued"] == [] and seq["playing"] is None, seq
        assert len(seq["done"]) + seq["dropped_total"] in (DANCES - 1, DANCES), seq
        assert ["stopped", by, "the test"] in rt.get("nudger")["told"]
        # the robot's trace, read while it is STOPPED
        lines = trace.read_text().splitlines()
        at, moved = after_stop(lines)
        assert moved == [], moved[:5]
        cut = len(frames(lines))        # (the CLI's STOP may come after the last dance)
        # a second STOP keeps the first one's who and when
        assert rt.stop_robot("again", by="someone")["by"] == by
        release(how, rt)
        assert rt.latched is None
        m = len(outcomes(rt))
        wait_for(lambda: ["ok", ""] in outcomes(rt)[m:], timeout=20,
                 what="a command going through after the release")
        assert ["released", "operator"] in rt.get("nudger")["told"]
        done = len(seq["done"])
        seq = rt.get("sequencer")
        assert seq["playing"] is None and seq["queued"] == [] and len(seq["done"]) == done, seq
    finally:
        emu.stop()
    lines = trace.read_text().splitlines()
    assert len(frames(lines)) == cut         # nothing queued played after the release
    assert any(line.startswith("W 10 ") and len(line.split()[2]) == 6
               for line in lines[at:]), "no servo moved after the release"


def test_a_stop_while_the_link_is_down_reaches_the_robot_first(start, tmp_path):
    trace = tmp_path / "trace.txt"
    emu = EmulatedRobot(PAPAMAN)
    emu.start()
    try:
        rt = start(example(emu.port, **nudger()))
        rt.wait_state("nudger", "running")
        emu.kill()
        wait_for(lambda: rt.state("papaman.servo.l_knee") == "lost", timeout=20,
                 what="the link down")
        rt.stop_robot("pulled")
        emu.start(["--trace", str(trace), "--trace-rx"])          # plugged back
        wait_for(lambda: rt.state("papaman.servo.l_knee") == "ready", timeout=30,
                 what="the link back")
        n = len(outcomes(rt))
        got = wait_for(lambda: len(o := outcomes(rt)[n:]) >= 3 and o, timeout=20,
                       what="commands after the link came back")
        assert all(kind == "CommandError" and REFUSAL.fullmatch(text) for kind, text in got), got
    finally:
        emu.stop()
    received = [line for line in trace.read_text().splitlines()
                if line.startswith("RX ") and line != "RX 0D"]
    assert received[:2] == [STOP_LINE, HOLD_LINE], received[:3]
    assert set(received) <= QUIET, sorted(set(received) - QUIET)


def test_a_release_while_the_link_is_down_reaches_the_robot_when_it_is_back(start, tmp_path):
    """The release's ``h0`` (the firmware's reactions let go) cannot go while the link is
    down: it goes when the link is back, and no ``x`` or ``h1`` with it."""
    trace = tmp_path / "trace.txt"
    emu = EmulatedRobot(PAPAMAN)
    emu.start()
    try:
        rt = start(example(emu.port))
        rt.wait_state("sequencer", "running")
        rt.stop_robot("pulled")
        emu.kill()
        wait_for(lambda: rt.state("papaman.motion") == "lost", timeout=20,
                 what="the link down")
        rt.release_robot()
        emu.start(["--trace", str(trace), "--trace-rx"])          # plugged back
        wait_for(lambda: RELEASE_LINE in trace.read_text().splitlines(), timeout=30,
                 what="the release's h0 after the link came back")
    finally:
        emu.stop()
    received = [line for line in trace.read_text().splitlines()
                if line.startswith("RX ") and line != "RX 0D"]
    assert STOP_LINE not in received and HOLD_LINE not in received, received[:5]


def test_only_the_operator_releases_and_a_behavior_stops_only_when_granted(start, tmp_path):
    emu = EmulatedRobot(PAPAMAN)
    emu.start()
    try:
        dep = example(emu.port, **nudger(),
                      stopper={"class": "tests.support.papaman_comps:Stopper", "may_stop": True},
                      nostop={"class": "tests.support.papaman_comps:Stopper"})
        rt = start(dep, control=True, stopped=True)
        rt.wait_state("nudger", "running")
        assert rt.latched["reason"] == "started stopped (--stopped)"
        n = len(outcomes(rt))
        got = wait_for(lambda: len(o := outcomes(rt)[n:]) >= 2 and o, timeout=20,
                       what="commands while started STOPPED")
        assert all(REFUSAL.fullmatch(text) for _, text in got), got
        # the state where the operator looks: ls (its last line), top (its title), ping
        stopped = ("STOPPED by operator at {} (started stopped (--stopped)): release with "
                   "esair std release")
        at = rt.latched["at"]
        assert esair("ls", "-e", rt.endpoint).stdout.splitlines()[-1] == stopped.format(at)
        assert esair("ls", "--json", "-e", rt.endpoint).stdout.count('"by": "operator"') == 1
        top = esair("top", "--count", "1", "--interval", "0.1", "-e", rt.endpoint).stdout
        assert f"— {stopped.format(at)}" in " ".join(top.split())     # its title, wrapped
        assert esair("ping", "-e", rt.endpoint).stdout.rstrip().endswith(stopped.format(at))
        server = rt.server
        with pytest.raises(Refused, match="behavior 'nudger' may not release the STOP"):
            from esair_std.transport import wire
            wire.result(server.answer("release", {"who": "nudger"}))
        with pytest.raises(Refused, match="behavior 'nudger' may not STOP the robot"):
            wire.result(server.answer("stop", {"who": "nudger"}))
        assert rt.release_robot()["by"] == "operator"
        with pytest.raises(ControlError, match="the robot is not stopped: nothing to release"):
            rt.release_robot()
        # a behavior STOPs the robot only when its entry grants it
        rt.put("stopper", "tipping", timeout=5.0)
        rt.put("nostop", "tipping", timeout=5.0)
        wait_for(lambda: rt.get("stopper") == [""] and rt.get("nostop") != [], timeout=20,
                 what="both behaviors' tries")
        assert rt.get("nostop") == ["Refused: behavior 'nostop' may not STOP the robot (its "
                                    "deployment entry would say 'may_stop: true')"]
        assert (rt.latched["by"], rt.latched["reason"]) == ("stopper", "tipping")
        rt.release_robot()
        r = esair("ping", "-e", rt.endpoint)
        assert r.stdout.rstrip().endswith(": running"), r.stdout
    finally:
        emu.stop()


def test_a_remote_agents_commands_are_refused_too(tmp_path):
    """A behavior on another computer (``esair std agent``): its commands go straight
    to the actuator's host, which refuses them while STOPPED; it is told, and its
    commands move the robot again after the release."""
    import subprocess
    import sys

    from esair_std import Runtime
    from tests.support.std import free_endpoint

    emu = EmulatedRobot(PAPAMAN)
    emu.start()
    dep = example(emu.port)
    dep["resources"]["papaman"]["allow"]["far"] = "command"
    rt = Runtime(dep, mode="process", endpoint=free_endpoint())
    proc = None
    try:
        rt.start()
        proc = subprocess.Popen([sys.executable, "-m", "esair_min.cli", "std", "agent",
                                 "--connect", rt.endpoint, "far",
                                 "tests.support.papaman_comps:Nudger",
                                 "--uses", "papaman.servo.*=command"], cwd=ROOT,
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        rt.wait_state("far", "running", timeout=60)

        def far() -> dict:
            return rt.get("far", timeout=5.0)
        wait_for(lambda: ["ok", ""] in far()["outcomes"], timeout=20, what="a first move")
        rt.stop_robot("remote")
        n = len(far()["outcomes"])
        got = wait_for(lambda: len(o := far()["outcomes"][n:]) >= 3 and o, timeout=20,
                       what="the remote behavior's commands while STOPPED")
        assert all(kind == "CommandError" and REFUSAL.fullmatch(text) for kind, text in got), got
        assert ["stopped", "operator", "remote"] in far()["told"]
        rt.release_robot()
        m = len(far()["outcomes"])
        wait_for(lambda: ["ok", ""] in far()["outcomes"][m:], timeout=20,
                 what="its commands going through after the release")
    finally:
        if proc is not None:
            proc.terminate()
            proc.wait(30)
        rt.stop()
        emu.stop()


def test_the_firmwares_balance_reaction_is_held_while_stopped(start, tmp_path):
    """PAPA-MAN's firmware reacts by itself: a push fires its balance reaction, which
    plays a motion. A runtime started STOPPED tells the robot ``x`` then ``h1`` before
    any moving line; the push then sends ``!H auto_balance`` (held) and, by the robot's
    own trace, no servo is written at all. After the release (``h0``) the same push
    fires ``!R auto_balance`` and the balance motion moves the servos again. (No host
    behavior commands the robot here: the moves are the firmware's.)"""
    trace = tmp_path / "trace.txt"
    emu = EmulatedRobot(PAPAMAN, ["--trace", str(trace), "--trace-rx", "--scenario",
                                  str(push_soon(tmp_path)), "--hold-scenario"])
    emu.start()
    try:
        dep = example(emu.port)
        del dep["behaviors"]["watcher"], dep["behaviors"]["logger"]
        rt = start(dep, stopped="the push")
        rt.wait_state("sequencer", "running")
        wait_for(lambda: HOLD_LINE in trace.read_text().splitlines(), timeout=30,
                 what="the robot told to hold its reactions")
        emu.play_scenario()
        wait_for(lambda: HELD_NOTICE in trace.read_text().splitlines(), timeout=30,
                 what="the reaction held (its !H notice)")
        wait_for(lambda: trace.read_text().splitlines().count(HELD_NOTICE) >= 2, timeout=30,
                 what="the push held to its end")
        rt.release_robot()
        wait_for(lambda: RELEASE_LINE in trace.read_text().splitlines(), timeout=30,
                 what="the robot told to release its reactions")
        emu.play_scenario()
        wait_for(lambda: len(servo_writes(trace.read_text().splitlines())) >= 3, timeout=30,
                 what="the balance motion's frames after the release")
    finally:
        emu.stop()
    lines = trace.read_text().splitlines()
    received = [line for line in lines if line.startswith("RX ") and line != "RX 0D"]
    held = received.index(HOLD_LINE)         # the link's v and polls may come first
    assert received[held - 1] == STOP_LINE and set(received[:held]) <= QUIET, received[:held]
    released = lines.index(RELEASE_LINE)
    assert NOTICE not in lines[:released] and HELD_NOTICE in lines[:released]
    assert servo_writes(lines[:released]) == []
    assert NOTICE in lines[released:] and HELD_NOTICE not in lines[released:]
    writes = servo_writes(lines)
    assert writes and all(i > lines.index(NOTICE) for i in writes)


NOTICE = "TX " + b"!R auto_balance\r\n".hex().upper()
HELD_NOTICE = "TX " + b"!H auto_balance\r\n".hex().upper()


def servo_writes(lines: list[str]) -> list[int]:
    """Indexes of the acknowledged writes to the actuator board."""
    return [i for i, ln in enumerate(lines) if ln.startswith("W 10 ") and ln.endswith(" ACK")]


@pytest.mark.slow
def test_starfish_wheels_go_to_zero_and_stay_there(start):
    """STARFISH's wheels, judged by its own odometry (the flow sensors): driving, then
    STOPPED: the pose stops changing (the odometry polls go on, so the board's 0.5 s
    watchdog never fires: only the STOP's ``x`` stops the wheels), the wheels' next
    command is refused; released, a command drives it again."""
    room = str(ROOT / "esair_std/examples/starfish/room.yaml")
    rt = start({"resources": {"starfish": {
        "class": "esair_std.drivers.starfish:Starfish", "room_file": room,
        "allow": {"*": "read", "operator": "command"}}}}, control=True)
    from esair_std.errors import CommandError
    from tests.support.std import ask

    def pose() -> tuple[float, float]:
        v = ask(rt.endpoint, "sample", {"name": "starfish.odometry", "timeout": 5})["value"]
        return v["x"], v["y"]
    drive = {"name": "starfish.wheels", "value": {"vx": 200}, "timeout": 2}
    ask(rt.endpoint, "send", drive)
    p0 = pose()
    wait_for(lambda: pose() != p0, timeout=20, what="the robot driving")
    rt.stop_robot("wheels")
    import time

    def still() -> bool:                 # several polls' worth without a change
        a = pose()
        time.sleep(0.3)
        return pose() == a
    wait_for(still, timeout=10, what="the pose at rest")
    rest = pose()
    time.sleep(1.0)                      # twice the watchdog: it must not be what stopped it
    assert pose() == rest
    with pytest.raises(CommandError, match="stopped by operator at "):
        ask(rt.endpoint, "send", drive)
    rt.release_robot()
    ask(rt.endpoint, "send", drive)
    wait_for(lambda: pose() != rest, timeout=20, what="the robot driving again")


def test_esair_std_run_stopped_starts_latched():
    """``esair std run --stopped``: the runtime answers STOPPED from its first answer."""
    import signal
    import subprocess
    import sys

    from tests.support.std import ask, free_endpoint
    ep = free_endpoint()
    proc = subprocess.Popen([sys.executable, "-m", "esair_min.cli", "std", "run", "lab",
                             "--stopped", "-e", ep, "--no-top"], cwd=ROOT,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        ping = wait_for(lambda: proc.poll() is None and ask(ep, "ping"), timeout=60,
                        what="the runtime answering")
        assert (ping["stopped"]["by"], ping["stopped"]["reason"]) == (
            "operator", "started stopped (--stopped)")
        wait_for(lambda: proc.poll() is not None or ask(ep, "ping")["starting"] is False,
                 timeout=60, what="the runtime started")
    finally:
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
