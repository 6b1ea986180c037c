"""What the robot was last told, as the HMI keeps it (esair_std/hmi/commanded.py): a
command of this HMI is answered, and the actuator's record of it comes, in either order
(the record on Zenoh's thread, the answer through the runtime's control endpoint); the
motion's start and STOP times are the first that came, recorded once, and no stale entry
of "this HMI's own" is left to hide a later identical command of another sender. The
order is forced here (it is a race between two paths in the running system)."""

from __future__ import annotations

import time

from esair_std.hmi.bridge import took
from esair_std.hmi.commanded import PoseBook

MOTION = "papaman.motion"
DANCE = {"play": "dance"}
KNEE = "papaman.servo.l_knee"


def test_a_record_before_the_answer_gives_the_start_time_once():
    book = PoseBook()
    asked = book.asked(MOTION, DANCE)
    shown = book.ran(MOTION, DANCE, 100.0)          # the record first: shown at once
    assert shown == {"t": "commanded", "r": MOTION, "v": DANCE}
    book.answered(asked)
    assert book.sent(MOTION, DANCE, 100.04) is None  # the answer: not shown again
    assert book.played[MOTION] == (DANCE, 100.0, None)
    assert list(book.own) == [] and list(book.early) == []
    # a later identical command of another sender (a behavior) is shown, not taken for
    # this HMI's own record
    assert book.ran(MOTION, DANCE, 101.0) == {"t": "commanded", "r": MOTION, "v": DANCE}
    assert book.played[MOTION] == (DANCE, 101.0, None)


def test_an_answer_before_the_record_keeps_the_earlier_time():
    book = PoseBook()
    asked = book.asked(MOTION, DANCE)
    book.answered(asked)
    assert book.sent(MOTION, DANCE, 200.05) == {"t": "commanded", "r": MOTION, "v": DANCE}
    assert book.played[MOTION] == (DANCE, 200.05, None)
    assert book.ran(MOTION, DANCE, 200.0) is None    # this HMI's own: shown already
    assert book.played[MOTION] == (DANCE, 200.0, None)
    # STOP: its answer, then its record with an earlier time: the corrected position is
    # sent to the pages
    asked = book.asked(MOTION, "stop")
    book.answered(asked)
    assert book.sent(MOTION, "stop", 200.2) == {
        "t": "commanded", "r": MOTION, "v": "stop",
        "played": {"v": DANCE, "ms": 200.0, "stopped": True}}
    assert book.played[MOTION] == (DANCE, 200.0, 200.2)
    assert book.ran(MOTION, "stop", 200.15) == {
        "t": "commanded", "r": MOTION, "v": "stop",
        "played": {"v": DANCE, "ms": 150.0, "stopped": True}}
    assert book.played[MOTION] == (DANCE, 200.0, 200.15)
    assert book.ran(MOTION, "stop", 200.3) == {   # another sender's STOP: where it stopped
        "t": "commanded", "r": MOTION, "v": "stop",
        "played": {"v": DANCE, "ms": 150.0, "stopped": True}}
    assert list(book.own) == [] and book.asking == []


def test_a_failed_command_leaves_nothing_waiting():
    book = PoseBook()
    asked = book.asked(MOTION, DANCE)
    book.answered(asked)                              # refused: no record comes
    assert book.asking == [] and list(book.own) == [] and MOTION not in book.played
    assert book.hello(10.0) == []
    # the same command from a behavior later is shown with its own time
    assert book.ran(MOTION, DANCE, 5.0) == {"t": "commanded", "r": MOTION, "v": DANCE}
    assert book.played[MOTION] == (DANCE, 5.0, None)


def test_a_motion_replaces_the_servos_and_later_servo_commands_come_after_it():
    book = PoseBook()
    book.ran(KNEE, {"angle": 40}, 1.0)
    book.ran("papaman.servo.r_knee", {"angle": 50}, 1.1)
    book.ran(MOTION, DANCE, 2.0)                     # every servo moves: their entries go
    book.ran(KNEE, {"angle": 60}, 3.0)
    assert book.hello(3.5) == [
        [MOTION, DANCE, {"v": DANCE, "ms": 1500.0, "stopped": False}],
        [KNEE, {"angle": 60}]]


def test_a_stop_of_a_motion_not_seen_keeps_the_pose_it_has():
    """A STOP with no motion known (an HMI started after the motion, a STOP clicked twice)
    moves nothing: the servos' last commands and the last motion stay for a new page,
    not a bare "stop" that rebuilds nothing (every joint at its default)."""
    book = PoseBook()
    book.ran(KNEE, {"angle": 40}, 1.0)
    assert book.ran(MOTION, "stop", 2.0) == {"t": "commanded", "r": MOTION, "v": "stop"}
    assert book.hello(3.0) == [[KNEE, {"angle": 40}]]
    book.ran(MOTION, DANCE, 4.0)
    book.ran(MOTION, "stop", 4.5)
    book.ran(MOTION, "stop", 9.0)                    # a second STOP: where the first left it
    assert book.hello(10.0) == [[MOTION, DANCE, {"v": DANCE, "ms": 500.0, "stopped": True}]]


def test_the_time_a_command_took_is_the_drivers_when_it_says():
    # a MIN link's motion says when the robot had its whole line (driver.py)
    assert took({"line": "PLY03", "at": 12.5}) == 12.5
    # anything else: when its answer or record came
    for result in ("ojc123", {"line": "x"}, {"at": True}, None, {"at": "soon"}):
        assert abs(took(result) - time.time()) < 60
