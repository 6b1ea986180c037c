"""The MIN link (esair_std.drivers.minlink) against the in-process emulator (esair://).

Budget and command checks are pure; the link tests run the real emulator behind
pySerial's esair:// URL (real time), one command in flight.
"""

from __future__ import annotations

import shutil
import threading
import time
from pathlib import Path

import pytest
import serial

from esair_min.core.protocol import Code
from esair_min.model.validate import load_robot
from esair_std.drivers.minlink import Link, LinkDown, LinkError, RobotRefused, line_budget
from esair_std.drivers.minlink.link import WIRE_CODES
from tests.support.board_lines import text, version

ROOT = Path(__file__).resolve().parents[2]
PAPAMAN = ROOT / "boards" / "papaman"
URL = f"esair://{PAPAMAN}"


@pytest.fixture(scope="module")
def robot():
    return load_robot(PAPAMAN)


def _io_threads() -> list[str]:
    return [t.name for t in threading.enumerate() if t.name.startswith("minlink-io")]


def test_feet_poll_rate_is_checked_against_the_line(robot):
    budget = line_budget(robot)
    # "s\r\n" out, "OK " + 8 readings of up to 4 digits + 7 commas + CR LF back, the
    # central board's 16-register read of the sensor board (174 bit times at 100 kHz)
    assert (budget.feet_request_bytes, budget.feet_reply_bytes) == (3, 44)
    assert budget.feet_exchange_s == pytest.approx(47 * 10 / 9600 + 174 / 100_000)
    budget.check_feet_hz(9.8)
    with pytest.raises(LinkError) as exc:
        budget.check_feet_hz(50)
    assert str(exc.value) == (
        "feet poll rate 50 Hz exceeds the line's budget: at 9600 baud one 's' exchange "
        "takes up to 50.7 ms (3 bytes out, 44 back), so 50% of the line allows at most 9.9 Hz")
    budget.check_feet_hz(19, share=1.0)
    with pytest.raises(LinkError, match="must be more than 0"):
        budget.check_feet_hz(0)


def test_commands_outside_the_board_files_are_refused_before_sending(robot):
    link = Link(robot, URL)                     # never opened: nothing can be sent
    cmds = link.commands
    assert cmds.motor("l_knee", 120, 3) == "odd120"
    assert cmds.motor("r_ankle_roll", 60) == "olc060"      # default speed 2 from the file
    with pytest.raises(LinkError) as exc:
        cmds.motor("l_knee", 151)
    assert str(exc.value) == ("servo l_knee: angle 151 is outside its limits 0..150 "
                              f"({PAPAMAN / 'actuator.yaml'}); not sent")
    with pytest.raises(LinkError, match=r"^servo r_knee: angle 29 is outside its limits 30\.\.180"):
        cmds.motor("r_knee", 29)
    with pytest.raises(LinkError, match=r"^robot papaman has no servo 'knee' \(servos: l_hip_yaw,"):
        cmds.motor("knee", 90)
    with pytest.raises(LinkError, match=r"^servo l_knee: speed 26 is not a speed code 0\.\.25$"):
        cmds.motor("l_knee", 90, 26)
    with pytest.raises(LinkError, match=r"^servo l_knee: angle 90\.5 is not a whole number"):
        cmds.motor("l_knee", 90.5)
    assert cmds.play("dance") == "PLY03" and cmds.play(2) == "PLY02"
    with pytest.raises(LinkError, match=r"^robot papaman has no motion 'jump' \(motions: stand, sit,"):
        cmds.play("jump")
    with pytest.raises(LinkDown) as exc:
        link.command("v")
    assert str(exc.value) == f"link to {URL} is down (not opened): 'v' not sent"


def test_replies_are_matched_and_errors_name_the_command(robot):
    with Link(robot, URL) as link:
        assert link.version() == text(version(robot))[3:]
        link.stand()
        link.motor("l_knee", 120, 3)
        with pytest.raises(RobotRefused) as exc:
            link.command("PLY77")
        assert str(exc.value) == "robot refused 'PLY77': E08 no such motion"
        assert (exc.value.command, exc.value.code) == ("PLY77", Code.NO_MOTION)
        link.play("prostrate")
        with pytest.raises(RobotRefused, match=r"^robot refused 't': E07 busy$"):
            link.stand()
        link.stop()
        feet = link.feet()
        assert feet["groups"] == {"left_foot": 2048, "right_foot": 2048}
        assert link.stats["strays"] == 0 and link.stats["refused"] == 2
    # the push (1.1 s .. 1.5 s of the robot's time, from its boot: a robot of its own,
    # booted here, so the commands above, however slow on a busy machine, never eat into
    # it) fires the firmware's reaction: its notice comes on the notices stream while
    # feet polls go on, never as a reply
    with Link(robot, URL + "?scenario=push") as link:
        deadline = time.monotonic() + 10
        seen: list[str] = []
        tilted = False
        while "R auto_balance" not in seen and time.monotonic() < deadline:
            tilted |= link.feet()["groups"]["left_foot"] > 2048
            seen += [text for text, _ in link.notices()]
        assert "R auto_balance" in seen and tilted
        assert link.stats["strays"] == 0 and link.stats["refused"] == 0
    assert _io_threads() == []


def test_checksums_are_sent_when_the_board_file_requires_them(tmp_path, robot):
    folder = tmp_path / "papaman"
    shutil.copytree(PAPAMAN, folder)
    central = folder / "central.yaml"
    central.write_text(central.read_text().replace("require_checksum: false",
                                                   "require_checksum: true"))
    strict = load_robot(folder)
    url = f"esair://{folder}"
    with Link(strict, url) as link:
        assert " checksum=on build=" in link.version()
        link.stand()                                  # sent as "t*74"
        link.motor("l_knee", 100)
        assert link.commands.wire("t") == b"t*74\r\n"
    with serial.serial_for_url(url, timeout=2) as raw:   # the same robot refuses bare lines
        raw.write(b"t\r\n")
        assert raw.readline().startswith(b"!READY")
        assert raw.readline() == b"E11 checksum required\r\n"
    with pytest.raises(LinkError) as exc:             # the board files must match the robot
        Link(robot, url).open()
    assert str(exc.value) == (f"the robot on {url} requires checksums (E11) but the board "
                              f"files of papaman say require_checksum: false ({PAPAMAN})")
    with pytest.raises(LinkError) as exc:             # ... both ways
        Link(strict, URL).open()
    assert str(exc.value) == ("the robot answers checksum=off but the board files of papaman "
                              f"say checksum=on ({folder})")
    assert _io_threads() == []


def test_line_noise_never_mismatches_a_reply(robot):
    # random bytes on the robot's receive line: some lines are damaged (an E01/E03/E13
    # names the command), some replies answer lines the noise made up (strays); every
    # OK must have the shape of its own command
    lines = ["v", "s", "x"] * 15
    refused, ok = [], 0
    with Link(robot, URL + "?noise=15&seed=7") as link:
        for line in lines:
            try:
                data = link.command(line)
            except RobotRefused as exc:
                assert exc.command == line and exc.code in WIRE_CODES
                refused.append(exc.code)
                continue
            ok += 1
            if line == "v":
                assert data.startswith("esair-min/1 servos=12")
            elif line == "s":
                assert len(data.split(",")) == 8
            else:
                assert data == ""
        stats = dict(link.stats)
    assert refused and ok > len(lines) // 2, (refused, ok, stats)
    assert stats["sent"] == len(lines) + 0 and stats.get("downs", 0) == 0


def test_board_faults_surface_on_the_command(robot):
    with Link(robot, URL + "?nack=actuator") as link:
        with pytest.raises(RobotRefused, match=r"^robot refused 't': E10 no answer on i2c$"):
            link.stand()
        with pytest.raises(RobotRefused, match=r"^robot refused 'odd120': E10 no answer on i2c$"):
            link.motor("l_knee", 120, 3)
        assert link.feet()["groups"]["left_foot"] == 2048      # the sensor board answers
    with Link(robot, URL + "?stuck=bus") as link:
        with pytest.raises(RobotRefused, match=r"^robot refused 's': E10 no answer on i2c$"):
            link.feet()
        assert link.version().endswith(text(version(robot, False)).split(" image=")[1])
        assert link.up
    assert _io_threads() == []


def test_callers_at_once_queue_in_order_and_each_gets_its_own_reply(robot):
    """Four threads command one link at once: one command is in flight, the others wait
    in a queue and go out in arrival order as soon as the reply before them is matched;
    every caller gets the reply of its own command (shape checked), none is lost."""
    shapes = {"v": lambda d: d.startswith("esair-min/1 servos=12"),
              "s": lambda d: len(d.split(",")) == 8, "x": lambda d: d == ""}
    got: dict[str, list[bool]] = {}
    with Link(robot, URL) as link:
        def caller(line: str) -> None:
            got[line] = [shapes[line](link.command(line)) for _ in range(25)]
        threads = [threading.Thread(target=caller, args=(line,)) for line in ("v", "s", "x")]
        for t in threads:
            t.start()
        for t in threads:
            t.join(30)
        stats = dict(link.stats)
        assert link.waiting == 0 and link.in_flight == 0
    assert got == {line: [True] * 25 for line in ("v", "s", "x")}
    assert stats["sent"] == stats["ok"] == 75 and stats.get("strays", 0) == 0


def test_a_command_waiting_its_turn_fails_not_sent(robot):
    """A command that cannot get its turn within its timeout fails saying it was not
    sent (counted as expired); the one in flight is answered. (A second ``s`` never
    goes out beside the first: two replies of one shape could pass for one another.)"""
    # the robot at a tenth of real time: the first 's' (~50 ms on the line at 9600 baud)
    # stays in flight ~0.5 s of wall time, so a test thread held up by a busy machine
    # still asks the second while the first waits for its reply
    with Link(robot, URL + "?speed=0.1", timeout=5.0) as link:
        out: dict[str, object] = {}

        def slow() -> None:
            out["s"] = len(link.command("s").split(","))
        t = threading.Thread(target=slow)
        t.start()
        deadline = time.monotonic() + 5
        while link.in_flight == 0 and time.monotonic() < deadline:
            time.sleep(0.0005)
        with pytest.raises(LinkError) as exc:
            link.command("s", timeout=0.001)
        assert str(exc.value) == (f"link to {URL}?speed=0.1: 's' not written within its "
                                  f"deadline; dropped")
        t.join(5)
        assert out == {"s": 8} and link.stats["expired"] == 1 and link.waiting == 0


def test_papaman_avr_feet_are_papaman_s_eight(robot):
    """papaman-avr (ATmega328P boards, the feet through the sensor board's mux) is the
    same robot to STD: the version line, the feet sample's eight names and the groups
    the reaction compares are PAPA-MAN's, from its emulator behind esair://."""
    avr_dir = ROOT / "boards" / "papaman-avr"
    with Link(load_robot(avr_dir), f"esair://{avr_dir}") as link:
        assert link.version() == text(version(load_robot(avr_dir)))[3:]
        feet = link.feet()
    assert list(feet["values"]) == [s.name for s in robot.sensors]          # type: ignore[call-overload]
    assert feet["groups"] == {"left_foot": 2048, "right_foot": 2048}
    assert _io_threads() == []


def test_a_held_link_holds_the_firmwares_reactions_again_after_a_reset(robot):
    """Held, the link tells the robot ``x`` then ``h1`` (its core's reactions held). A
    reset while the port stays open releases them (RAM only): the robot's ``!READY``
    makes the link hold them again at once. ``hold(False)`` sends ``h0``."""
    from tests.support.std import wait_for

    with Link(robot, URL) as link:
        core = link._port.emulator.core
        assert link.hold(True) is not None
        wait_for(lambda: core.reactions_held, timeout=10, what="h1 after the x")
        with link._port._emu_lock:
            core.boot()                       # a reset in place: released, then !READY
        assert not core.reactions_held
        wait_for(lambda: core.reactions_held, timeout=10, what="h1 after the reset")
        assert link.stats["resets_while_held"] == 1 and link.stats["stops_sent"] == 2
        wait_for(lambda: link.stats["hold_lines_sent"] == 2, timeout=10, what="h1 answered")
        link.hold(False)
        assert not core.reactions_held and link.stats["hold_lines_sent"] == 3


def test_no_poll_goes_between_the_stop_line_and_h1(robot):
    """hold(True) writes ``h1`` right after the ``x`` (the window in which a reaction
    may still fire): polls asked all the while (the feet's, full duplex) wait for it."""
    from tests.support.std import wait_for

    with Link(robot, URL) as link:
        port = link._port
        written: list[bytes] = []
        write = port.write

        def logged(data: bytes) -> int | None:
            written.append(bytes(data))
            return write(data)
        port.write = logged
        polling = threading.Event()

        def poller() -> None:
            while not polling.is_set():
                link.exchange("s", poll=True)
        threads = [threading.Thread(target=poller) for _ in range(3)]
        for t in threads:
            t.start()
        try:
            wait_for(lambda: len(written) >= 3, timeout=10, what="the polls going")
            assert link.hold(True) is not None
            lines = [ln for ln in b"".join(written).split() if ln]
            at = lines.index(b"x")
            assert lines[at - 2:at].count(b"s") >= 1       # the polls went right up to it
            assert lines[at + 1] == b"h1", lines[at - 2:at + 3]
        finally:
            polling.set()
            for t in threads:
                t.join(10)
        assert link.stats["hold_lines_sent"] == 1
