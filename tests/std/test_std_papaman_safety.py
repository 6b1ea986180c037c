"""PAPA-MAN under STD, safe under faults of the robot (issue 19, items 1 and 2), in
both modes: the emulated robot the runtime owns is killed (SIGKILL) or stopped
(SIGSTOP); another `esair emulate` gets the dead robot's /dev/pts number.

- never another robot: the resources stay ``lost`` with the reason, or come back on
  the same robot (its restart policy), never on the other one, which gets no byte;
- never a stale motion: operations asked while the robot was stopped are dropped and
  reported, and the robot, back, plays none of them (its trace).
"""

from __future__ import annotations

import pytest

import functools
import os
import signal
import threading
import time
from pathlib import Path

import yaml

from esair_std.drivers.minlink.emulated import EmulatedRobot
from tests.support.std import emulators_with, wait_for
from tests.support.robot_ptys import VERSION, frames, pty_number, replies, start_on_number, stop
from tests.support.board_lines import READY_OK

pytestmark = pytest.mark.pty

ROOT = Path(__file__).resolve().parents[2]
PAPAMAN = ROOT / "boards" / "papaman"
EXAMPLE = ROOT / "esair_std" / "examples" / "papaman" / "papaman.yaml"
MOVER = {"class": "tests.support.papaman_comps:Mover", "moves": [], "uses": {"papaman.servo.*": "command"}}


_wait = functools.partial(wait_for, timeout=30.0)


def example(port: str, trace: Path | None = None, **extra) -> dict:
    """The bundled example deployment on ``port`` (its own emulated robot with
    ``trace`` for "emulate"), with ``extra`` behaviors."""
    dep = yaml.safe_load(EXAMPLE.read_text())
    entry = dep["resources"]["papaman"]
    entry["port"] = port
    if port == "emulate":
        entry["emulate"] = {"scenario": "quiet", "trace": str(trace)}
    else:
        entry.pop("emulate", None)
    for b in dep["behaviors"].values():
        b["class"] = "esair_std.examples.papaman." + b["class"]
    dep["behaviors"].update(extra)
    entry["allow"].update({name: "command" for name in extra})
    return dep


def robot_rows(rt) -> list[dict]:
    return [r for r in rt.ls() if r["name"].startswith("papaman.")]


def all_lost(rt, reason: str):
    rows = robot_rows(rt)
    return len(rows) == 15 and all(r["state"] == "lost" and r["reason"] == reason
                                   for r in rows) and rows


def all_ready(rt) -> bool:
    rows = robot_rows(rt)
    return len(rows) == 15 and all(r["state"] == "ready" for r in rows)


def move(rt, angle: int) -> list:
    """One servo move through the Mover behavior; its outcome."""
    n = len(rt.get("mover")["results"])
    rt.put("mover", {"servo": "l_knee", "angle": angle}, timeout=2.0)
    got = _wait(lambda: len((r := rt.get("mover"))["results"]) > n and r, what="the move")
    return got["results"][n]


def reaped(pid: int) -> bool:
    """The process is gone from /proc (a zombie would still be there)."""
    return not os.path.exists(f"/proc/{pid}")


def test_a_killed_robot_stays_lost_and_its_pty_number_is_never_driven(start, tmp_path):
    trace, other = tmp_path / "own.txt", tmp_path / "other.txt"
    rt = start(example("emulate", trace, mover=MOVER))
    [pid] = _wait(lambda: emulators_with(str(trace)), what="the emulated robot")
    number = pty_number(pid)
    assert move(rt, 100) == ["ok", "odc100"]
    os.kill(pid, signal.SIGKILL)
    _wait(lambda: all_lost(rt, "emulator exited (status -9)"), what="resources lost")
    _wait(lambda: reaped(pid), what="the dead robot reaped")
    foreign, _ = start_on_number(number, "--trace", str(other))
    try:
        assert move(rt, 110) == ["ResourceLost",
                                 "papaman.servo.l_knee: lost: emulator exited (status -9)"]
        time.sleep(2.0)            # the link's reconnect attempts (backoff 0.05 s doubling)
        assert all_lost(rt, "emulator exited (status -9)")
    finally:
        stop(foreign)
    assert replies(other) == [READY_OK]   # not a byte from us
    rt.stop()
    assert emulators_with(str(trace)) == []
    assert not [t for t in threading.enumerate() if t.name.startswith("minlink")]


def test_a_killed_robot_is_restarted_under_its_policy_then_stays_lost(start, tmp_path):
    trace = tmp_path / "own.txt"
    dep = example("emulate", trace, mover=MOVER)
    dep["resources"]["papaman"]["emulate"]["restart"] = {"max": 1, "within": 60}
    rt = start(dep)
    [pid] = _wait(lambda: emulators_with(str(trace)), what="the emulated robot")
    os.kill(pid, signal.SIGKILL)
    _wait(lambda: [p for p in emulators_with(str(trace)) if p != pid], what="a new robot")
    _wait(lambda: all_ready(rt), what="resources ready again")
    assert reaped(pid)
    assert move(rt, 120) == ["ok", "odc120"]
    [pid2] = emulators_with(str(trace))
    os.kill(pid2, signal.SIGKILL)
    why = "emulator exited (status -9); not restarted: 1 restart(s) within 60 s already"
    _wait(lambda: all_lost(rt, why), what="resources lost for good")
    _wait(lambda: reaped(pid2), what="the second robot reaped")
    assert emulators_with(str(trace)) == []
    assert move(rt, 130) == ["ResourceLost", f"papaman.servo.l_knee: lost: {why}"]


def test_a_different_robot_on_the_port_leaves_the_resources_lost(start, tmp_path):
    """The port is a path the runtime does not own (a udev link): the robot behind it
    dies and another one of the same board files takes its pty number. The link does not
    open that pty (made since); pointed at it anew, the link probes it and refuses it."""
    other = tmp_path / "other.txt"
    emu = EmulatedRobot(PAPAMAN, instance="aaaaaaaa")
    foreign = None
    try:
        port = emu.start()
        number = pty_number(emu.proc.pid)
        rt = start(example(port, mover=MOVER))
        assert move(rt, 100) == ["ok", "odc100"]
        os.kill(emu.proc.pid, signal.SIGKILL)             # its link /dev/pts/N stays
        foreign, path = start_on_number(number, "--instance", "bbbbbbbb", "--trace", str(other))
        gone = (f"the pty behind {port} went away and its number ({path}) now leads to "
                f"another program's pty: not opened (name the robot's new port, or a link "
                f"that follows it, as port: emulate does)")
        _wait(lambda: all_lost(rt, "link down: " + gone), what="resources lost: the pty gone")
        assert replies(other) == [READY_OK]                  # not a byte
        os.symlink(path, port + ".new")
        os.replace(port + ".new", port)                       # the udev link made anew
        why = f"a different robot answers on {port} (id bbbbbbbb, expected aaaaaaaa)"
        _wait(lambda: all_lost(rt, why), what="resources lost: another robot")
        assert move(rt, 110) == ["ResourceLost", f"papaman.servo.l_knee: lost: {why}"]
        rt.stop()
    finally:
        emu.stop()
        if foreign is not None:
            stop(foreign)
    got = replies(other)
    assert got[0] == READY_OK
    assert got[1:] and set(got[1:]) == {VERSION + b"bbbbbbbb\r\n"}      # probes only
    assert frames(other) == 0


def test_operations_asked_while_the_robot_is_stopped_are_never_played(start, tmp_path):
    """SIGSTOP, four dances asked (each delivered), SIGCONT 4 s later: the sequencer
    drops and reports the four, the robot, back, plays none (no frame in its trace)."""
    trace = tmp_path / "own.txt"
    rt = start(example("emulate", trace))
    rt.wait_state("sequencer", "running")
    [pid] = _wait(lambda: emulators_with(str(trace)), what="the emulated robot")
    _wait(lambda: all_ready(rt), what="resources ready")
    os.kill(pid, signal.SIGSTOP)
    stopped = time.monotonic()
    try:
        for _ in range(4):
            rt.put("sequencer", ["dance"], timeout=2.0)      # delivered (else it raises)
        _wait(lambda: all(r["state"] == "lost" for r in robot_rows(rt)), what="link lost")
        _wait(lambda: rt.get("sequencer")["dropped_total"] == 4, what="four dropped")
        time.sleep(max(0.0, stopped + 4.0 - time.monotonic()))
    finally:
        os.kill(pid, signal.SIGCONT)
    _wait(lambda: all_ready(rt), what="resources ready again")
    time.sleep(2.0)                # the stale dances came 0.3-1.3 s after the robot did
    got = rt.get("sequencer")
    assert got["done"] == [] and got["playing"] is None and got["queued"] == []
    assert got["dropped"] == ["dance"] * 4
    assert all(e.startswith("dance: ") for e in got["errors"])
    rt.stop()
    assert frames(trace) == 0
