"""Where a motion is, as the HMI server keeps it (server.py ``played``): a command of this
HMI is answered, and the actuator's record of it comes, in either order (the record on
Zenoh's thread, the answer through the runtime's control endpoint); the motion's start
and STOP times are the first that came, recorded once, and no stale entry of "this
HMI's own" is left to hide a later identical command of another sender. The order is
forced here (it is a race between two paths in the running system)."""

from __future__ import annotations

from esair_std.hmi.auth import Auth
from esair_std.hmi.bridge import took
from esair_std.hmi.server import HmiServer

MOTION = "papaman.motion"
DANCE = {"play": "dance"}


def server() -> HmiServer:
    return HmiServer("tcp/127.0.0.1:1", "127.0.0.1", 0, Auth("127.0.0.1"))


def test_a_record_before_the_answer_gives_the_start_time_once():
    srv = server()
    asked = srv._asked(MOTION, DANCE)
    shown = srv._ran(MOTION, DANCE, 100.0)          # the record first: shown at once
    assert shown == {"t": "commanded", "r": MOTION, "v": DANCE}
    srv._answered(asked)
    srv._sent(MOTION, DANCE, 100.04)                 # the answer: not recorded again
    assert srv.played[MOTION] == (DANCE, 100.0, None)
    assert list(srv._own) == [] and list(srv._early) == []
    # a later identical command of another sender (a behavior) is shown, not taken for
    # this HMI's own record
    assert srv._ran(MOTION, DANCE, 101.0) == {"t": "commanded", "r": MOTION, "v": DANCE}
    assert srv.played[MOTION] == (DANCE, 101.0, None)


def test_an_answer_before_the_record_keeps_the_earlier_time():
    srv = server()
    asked = srv._asked(MOTION, DANCE)
    srv._answered(asked)
    srv._sent(MOTION, DANCE, 200.05)
    assert srv.played[MOTION] == (DANCE, 200.05, None)
    assert srv._ran(MOTION, DANCE, 200.0) is None    # this HMI's own: shown already
    assert srv.played[MOTION] == (DANCE, 200.0, None)
    # STOP: its answer, then its record with an earlier time: the corrected position is
    # sent to the pages
    asked = srv._asked(MOTION, "stop")
    srv._answered(asked)
    srv._sent(MOTION, "stop", 200.2)
    assert srv.played[MOTION] == (DANCE, 200.0, 200.2)
    assert srv._ran(MOTION, "stop", 200.15) == {
        "t": "commanded", "r": MOTION, "v": "stop",
        "played": {"v": DANCE, "ms": 150.0, "stopped": True}}
    assert srv.played[MOTION] == (DANCE, 200.0, 200.15)
    assert srv._ran(MOTION, "stop", 200.3) == {   # another sender's STOP: where it stopped
        "t": "commanded", "r": MOTION, "v": "stop",
        "played": {"v": DANCE, "ms": 150.0, "stopped": True}}
    assert list(srv._own) == [] and srv._asking == []


def test_a_failed_command_leaves_nothing_waiting():
    srv = server()
    asked = srv._asked(MOTION, DANCE)
    srv._answered(asked)                              # refused: no record comes
    assert srv._asking == [] and list(srv._own) == [] and MOTION not in srv.played
    # the same command from a behavior later is shown with its own time
    assert srv._ran(MOTION, DANCE, 5.0) == {"t": "commanded", "r": MOTION, "v": DANCE}
    assert srv.played[MOTION] == (DANCE, 5.0, None)


def test_the_time_a_command_took_is_the_drivers_when_it_says():
    # a MIN link's motion says when the robot had its whole line (driver.py)
    assert took({"line": "PLY03", "at": 12.5}) == 12.5
    # anything else: when its answer or record came
    for result in ("ojc123", {"line": "x"}, {"at": True}, None, {"at": "soon"}):
        assert abs(took(result) - __import__("time").time()) < 60
