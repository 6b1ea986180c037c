"""The MIN link never drives another robot and never writes a stale command (issue 19,
items 1 and 2), against `esair emulate --pty` child processes on real ptys.

- Identity: the `v` reply's id names the board set and the emulator's boot; after a
  reconnect the link refuses a robot of another id, even one of the same board files
  that got the dead robot's /dev/pts number.
- Deadlines: a command not written within its deadline is dropped (never sent), one
  asked before the link came back too; a robot stopped (SIGSTOP) for longer than its
  power-loss pause does not play, when it resumes, what was written to it meanwhile.

Every test ends with no I/O thread and no child process left.
"""

from __future__ import annotations

import contextlib
import functools
import os
import signal
import threading
import time
from pathlib import Path
from typing import Iterator

import pytest

from esair_min.model.validate import load_robot
from esair_std.drivers.minlink import Link, LinkDown
from esair_std.drivers.minlink.emulated import EmulatedRobot
from esair_std.drivers.minlink.link_errors import DifferentRobot, Expired, LinkError
from tests.support.std import wait_for
from tests.support.robot_ptys import VERSION, frames, pty_number, replies, start_on_number, stop
from tests.support.board_lines import PAPAMAN as PAPAMAN_ROBOT, READY_OK, version
from esair_min.codegen.buildid import central_build_id

BUILD = central_build_id(PAPAMAN_ROBOT)

pytestmark = pytest.mark.pty

ROOT = Path(__file__).resolve().parents[2]
PAPAMAN = ROOT / "boards" / "papaman"


@pytest.fixture(scope="module")
def robot():
    return load_robot(PAPAMAN)


_wait = functools.partial(wait_for, timeout=10.0)


def _io_threads() -> list[str]:
    return [t.name for t in threading.enumerate() if t.name.startswith("minlink")]


# -- identity ---------------------------------------------------------------------------

def test_the_version_reply_names_the_board_set_and_the_emulators_boot(robot):
    with EmulatedRobot(PAPAMAN, instance="0123abcd") as emu, Link(robot, emu.port) as link:
        assert link.version().endswith(" checksum=off build=" + BUILD + " id=0123abcd")
        assert link.robot_id == "0123abcd"
    a, b = EmulatedRobot(PAPAMAN), EmulatedRobot(PAPAMAN)
    assert a.instance != b.instance                    # two robots, two ids


def test_a_robot_on_the_dead_robots_pty_number_is_refused(tmp_path, robot):
    """The robot is killed outright (its port's link still names /dev/pts/N); another
    `esair emulate` of the same board files gets N. The link, reconnecting, does not open
    a pty made since the one it had (not a byte); once the port's link is pointed at
    that pty anew, it asks it `v` and refuses it: it sends nothing else, and says which
    robot answers."""
    emu = EmulatedRobot(PAPAMAN, instance="aaaaaaaa")
    states: list[tuple[bool, str]] = []
    foreign = None
    try:
        port = emu.start()
        number = pty_number(emu.proc.pid)
        link = Link(robot, port, on_state=lambda up, why: states.append((up, why)))
        link.open()
        try:
            link.stand()
            os.kill(emu.proc.pid, signal.SIGKILL)        # not emu.kill(): the path stays
            _wait(lambda: not link.up, what="the link down")
            foreign, path = start_on_number(number, "--instance", "bbbbbbbb",
                                            "--trace", str(tmp_path / "foreign.txt"))
            gone = (f"the pty behind {port} went away and its number ({path}) now leads "
                    f"to another program's pty: not opened (name the robot's new port, or "
                    f"a link that follows it, as port: emulate does)")
            _wait(lambda: (False, gone) in states, what="the pty refused")
            assert replies(tmp_path / "foreign.txt") == [READY_OK]     # not a byte
            os.symlink(path, port + ".new")
            os.replace(port + ".new", port)               # the port's link made anew
            why = (f"a different robot answers on {port} (id bbbbbbbb, "
                   f"expected aaaaaaaa)")
            _wait(lambda: (False, why) in states, what="the refusal")
            with pytest.raises(LinkDown) as exc:
                link.play("dance")
            assert str(exc.value) == (f"link to {port} is down (reconnecting: {why}): "
                                      f"'PLY03' not sent")
            assert not link.up and link.stats["reconnects"] == 0
            assert states.count((False, why)) == 1        # said once, not at every attempt
            assert states.count((False, gone)) == 1
        finally:
            link.close()
    finally:
        emu.stop()
        if foreign is not None:
            stop(foreign)
    # the only line the other robot answered is the probe (a read-only `v`)
    got = replies(tmp_path / "foreign.txt")
    assert got[0] == READY_OK     # its boot, to nobody
    assert got[1:] and set(got[1:]) == {version(PAPAMAN_ROBOT, robot_id="bbbbbbbb")}
    assert frames(tmp_path / "foreign.txt") == 0
    assert _io_threads() == []


def test_a_known_robot_id_is_checked_at_the_first_connect(robot):
    with EmulatedRobot(PAPAMAN, instance="0123abcd") as emu, pytest.raises(DifferentRobot) as exc:
        Link(robot, emu.port, expect_id="99999999").open()
    assert str(exc.value) == (f"a different robot answers on {emu.port} (id 0123abcd, "
                              f"expected 99999999)")


def test_a_port_another_esair_program_holds_is_refused_without_a_byte(tmp_path, robot):
    """Every ESAIR program locks the port it opens: a second link (a runtime reconnecting
    to a /dev/pts/N that is now someone else's, another `esair send`) is refused at once
    and writes nothing; the first link's replies stay whole."""
    from esair_min.cli.send import open_port
    from esair_min.errors import EsairError

    trace = tmp_path / "t.txt"
    with EmulatedRobot(PAPAMAN, ["--trace", str(trace)], instance="0123abcd") as emu, \
            Link(robot, emu.port) as link:
        with pytest.raises(LinkError) as exc:
            Link(robot, emu.port).open()
        assert str(exc.value) == (f"cannot open {emu.port}: another program has the port "
                                  f"open (it holds the port's lock)")
        with pytest.raises(EsairError) as sent:
            open_port(emu.port, 9600, 1.0)
        assert str(sent.value) == str(exc.value)
        assert link.version().endswith(" checksum=off build=" + BUILD + " id=0123abcd")
    assert replies(trace)[1:] == [VERSION + b"0123abcd\r\n"] * 2    # the probe, version()
    assert _io_threads() == []


def test_a_link_waits_for_a_short_lived_holder_of_its_port(robot):
    """A link reconnecting to a pty number that is now this robot's holds the port for
    its probe, then lets go: the robot's own link, opening meanwhile, tries again (within
    LOCK_WAIT_S) and gets it."""
    from esair_min.serialport import open_port

    with EmulatedRobot(PAPAMAN, instance="0123abcd") as emu:
        holder = open_port(emu.port, baudrate=9600)
        link = Link(robot, emu.port)
        box: list = []
        t = threading.Thread(target=lambda: box.append(link.open()), daemon=True)
        t.start()
        try:
            _wait(lambda: link.stats["port_locked"] >= 1, what="the link finding it held")
        finally:
            holder.close()
        t.join(10)
        try:
            assert box == [None] and link.robot_id == "0123abcd"
        finally:
            link.close()
    assert _io_threads() == []


@contextlib.contextmanager
def _fake_robot(answers: list[bytes]) -> Iterator[tuple[str, list[bytes]]]:
    """A robot played by the test on a real pty: each line it receives that is ``v``
    gets the next of ``answers``; yields (port path, the lines it got)."""
    import select
    import tty

    master, slave = os.openpty()
    tty.setraw(slave)
    stop_r, stop_w = os.pipe()
    got: list[bytes] = []

    def play() -> None:
        buf = b""
        while True:
            ready, _, _ = select.select([master, stop_r], [], [])
            if stop_r in ready:
                return
            buf += os.read(master, 256)
            while b"\n" in buf:
                line, _, buf = buf.partition(b"\n")
                if line.strip(b"\r"):
                    got.append(line.strip(b"\r"))
                if line.strip(b"\r") == b"v" and answers:
                    os.write(master, answers.pop(0))

    thread = threading.Thread(target=play, daemon=True)
    thread.start()
    try:
        yield os.ttyname(slave), got
    finally:
        os.write(stop_w, b"x")
        thread.join(5)
        for fd in (master, slave, stop_r, stop_w):
            os.close(fd)


def test_a_damaged_version_reply_is_asked_again_not_believed(robot):
    """Without checksums, line noise can damage the `v` reply (bytes lost on the way,
    e.g. `sensors= oin= mg=a`); the link believes a reply that names another robot
    only when the next one says the same."""
    good = VERSION + b"0123abcd\r\n"
    damaged = b"OK esair-min/1 servos=12 sensors= oin= mg=a hcsmofi=8017\r\n"
    with _fake_robot([damaged, good]) as (port, got), Link(robot, port) as link:
        assert link.robot_id == "0123abcd"
        assert got == [b"v", b"v"]
    other = VERSION.replace(b"sensors=8", b"sensors=6") + b"0123abcd\r\n"
    with _fake_robot([other, other, good]) as (port, got):
        with pytest.raises(LinkError) as exc:
            Link(robot, port).open()
        assert str(exc.value) == (f"the robot answers sensors=6 but the board files of "
                                  f"papaman say sensors=8 ({PAPAMAN})")
        assert got == [b"v", b"v"]


# -- deadlines --------------------------------------------------------------------------

def test_a_command_not_written_within_its_deadline_is_dropped(tmp_path, robot):
    """The robot stops (SIGSTOP) while a feet poll is in flight: a motion asked then
    waits its turn, its deadline passes, it fails and is never written; when the robot
    runs again it plays nothing."""
    trace = tmp_path / "t.txt"
    with EmulatedRobot(PAPAMAN, ["--trace", str(trace)]) as emu, \
            Link(robot, emu.port, timeout=1.0) as link:
        link.stand()
        os.kill(emu.proc.pid, signal.SIGSTOP)
        try:
            poll = threading.Thread(target=lambda: pytest.raises(LinkDown, link.feet))
            poll.start()
            _wait(lambda: link.in_flight == 1, what="the poll in flight")
            with pytest.raises(Expired) as exc:
                link.command("PLY03", timeout=0.2)
            assert str(exc.value) == (f"link to {emu.port}: 'PLY03' not written within "
                                      f"its deadline; dropped")
            poll.join(10)
            assert not link.up and link.stats["expired"] == 1
        finally:
            os.kill(emu.proc.pid, signal.SIGCONT)
        _wait(lambda: link.up, what="the link back")
        asked = link.up_since - 0.001               # asked before it came back
        with pytest.raises(Expired) as exc:
            link.command("PLY03", asked=asked)
        assert str(exc.value) == (f"link to {emu.port}: 'PLY03' was asked before the "
                                  f"link came back; dropped")
        link.stand()
    assert frames(trace) == 2                           # the two stands, no dance
    assert _io_threads() == []


def test_what_a_stopped_robot_was_sent_is_not_played_when_it_resumes(tmp_path, robot):
    """A line written to the robot while it was stopped (SIGSTOP, longer than its
    power-loss pause): the link gives up on it, and the robot, resumed, never plays it."""
    trace = tmp_path / "t.txt"
    with EmulatedRobot(PAPAMAN, ["--trace", str(trace)]) as emu, \
            Link(robot, emu.port, timeout=1.0) as link:
        link.stand()
        os.kill(emu.proc.pid, signal.SIGSTOP)
        try:
            with pytest.raises(LinkDown) as exc:
                link.play("dance")                  # written, never answered
            assert "went down while 'PLY03' waited for its reply" in str(exc.value)
            time.sleep(1.5)                         # stopped for more than 1 s in all
        finally:
            os.kill(emu.proc.pid, signal.SIGCONT)
        _wait(lambda: link.up, what="the link back")
        assert link.version().startswith("esair-min/1 ")
    assert frames(trace) == 1                           # the stand, no dance
    assert replies(trace).count(b"OK\r\n") == 1      # the stand's: PLY03 never answered
    assert _io_threads() == []
