"""STARFISH's stand-in world, radio model and path planner (esair_std/drivers/starfish/)."""

import math
import sys

import pytest

from esair_std.drivers.starfish.linkswitch import LinkSwitch
from esair_std.drivers.starfish.planner import NoPath, plan
from esair_std.drivers.starfish.radio import RadioModel
from esair_std.drivers.starfish.room import Room
from esair_std.drivers.starfish.standin import CommandRefused, StandInWorld
from tests.support.std import wait_for


class Clock:
    def __init__(self):
        self.t = 0.0

    def __call__(self):
        return self.t


def world(pose=(1.0, 1.0, 0.0), **kw):
    clock = Clock()
    return StandInWorld(Room.from_dict({}), pose, clock=clock, **kw), clock


def test_pose_integrates_the_body_velocity_in_the_robot_frame():
    w, clock = world(pose=(1.0, 1.0, math.pi / 2))
    w.command(100, 0, 0)                     # 100 mm/s ahead = +y in the world
    clock.t = 0.4
    x, y, th = w.pose()
    assert (x, y, th) == pytest.approx((1.0, 1.04, math.pi / 2), abs=1e-9)
    w.command(0, 100, 500)                   # to the left while turning at 0.5 rad/s
    clock.t = 0.8
    x, y, th = w.pose()
    assert th == pytest.approx(math.pi / 2 + 0.2)
    assert x < 1.0 - 0.035 and y == pytest.approx(1.04, abs=0.01)


def test_the_watchdog_stops_a_robot_nobody_commands():
    w, clock = world()
    w.command(200, 0, 0)
    clock.t = 2.0
    x, _, _ = w.pose()
    assert x == pytest.approx(1.0 + 0.2 * 0.5, abs=0.006) and not w.moving()
    assert w.watchdog_stops == 1


def test_a_wall_stops_the_robot_and_is_counted():
    w, clock = world(pose=(2.0, 1.0, 0.0))   # the inner wall at x = 3
    for k in range(1, 20):
        w.command(400, 0, 0)
        clock.t = 0.25 * k
    x, _, _ = w.pose()
    assert 3.0 - 0.15 - 0.01 <= x < 3.0 - 0.15 and w.collisions >= 1


@pytest.mark.parametrize("cmd, message", [
    ((401, 0, 0), "vx 401 mm/s is outside the limit +-400 mm/s"),
    ((0, 0, -3001), "w -3001 mrad/s is outside the limit +-3000 mrad/s"),
    ((300, 300, 0), "speed 424 mm/s is over the limit 400 mm/s"),
    ((True, 0, 0), "vx must be a number, not True"),
    ((0, float("nan"), 0), "vy must be a number, not nan"),
])
def test_commands_outside_the_limits_are_refused_and_change_nothing(cmd, message):
    w, clock = world()
    w.command(100, 0, 0)
    with pytest.raises(CommandRefused) as exc:
        w.command(*cmd)
    assert str(exc.value) == message
    clock.t = 0.1
    assert w.pose()[0] == pytest.approx(1.01)


def test_the_radio_is_cut_out_of_range_and_behind_a_wall_and_heals_inside_the_edge():
    radio = RadioModel(Room.from_dict({"access_point": [1.0, 1.0]}), range_m=3.0, heal_m=0.1)
    assert radio.update(3.9, 1.0 + 0.0)["up"] is False            # behind the inner wall
    assert radio.update(2.0, 3.0) == {"up": True, "distance": 2.236, "los": True}
    assert radio.update(3.1, 3.2)["up"] is False                  # 3.04 m: out of range
    assert radio.update(2.95, 3.2)["up"] is False                 # 2.94 m: not yet healed
    assert radio.update(2.85, 3.2)["up"] is True                  # 2.87 m
    assert radio.cuts == 2


def test_the_planner_goes_around_the_inner_wall():
    room = Room.from_dict({})
    path = plan(room, (4.5, 1.0), (1.0, 1.0), margin=0.25)
    points = [(4.5, 1.0)] + path
    assert path[-1] == (1.0, 1.0)
    assert max(y for _, y in path) > 2.5 + 0.2                   # through the gap at the top
    for p, q in zip(points, points[1:], strict=False):
        assert not room.blocked(p, q)
        for k in range(21):
            m = (p[0] + (q[0] - p[0]) * k / 20, p[1] + (q[1] - p[1]) * k / 20)
            assert room.clearance(m) >= 0.24
    # a free straight line is one waypoint
    assert plan(room, (1.0, 1.0), (2.0, 3.0)) == [(2.0, 3.0)]


def test_no_path_says_so():
    room = Room.from_dict({"walls": [[0, 0, 6, 0], [6, 0, 6, 4], [6, 4, 0, 4], [0, 4, 0, 0],
                                     [3, 0, 3, 4]]})
    with pytest.raises(NoPath) as exc:
        plan(room, (4.5, 1.0), (1.0, 1.0), margin=0.25)
    assert str(exc.value) == "no path from (4.50, 1.00) to (1.00, 1.00) keeps 0.25 m from the walls"


def test_the_link_switch_runs_ip_for_the_newest_wanted_state(tmp_path):
    log = tmp_path / "ip.log"
    fake_ip = (sys.executable, "-c",
               f"import sys; open({str(log)!r}, 'a').write(' '.join(sys.argv[1:]) + chr(10))")
    sw = LinkSwitch("eth9", command=fake_ip)
    sw.set(True)
    wait_for(lambda: sw.applied is True, 20, "the link up")
    sw.set(False)
    wait_for(lambda: sw.applied is False, 20, "the link down")
    sw.close()
    assert log.read_text().splitlines() == ["eth9 up", "eth9 down"] and sw.failures == 0


def test_a_failing_ip_is_counted_with_its_message():
    sw = LinkSwitch("eth9", command=(sys.executable, "-c", "import sys; sys.exit('no such device')"))
    sw.set(False)
    wait_for(lambda: sw.failures >= 1, 20, "a failure")
    sw.close()
    assert sw.last_error == "no such device" and sw.applied is None
    with pytest.raises(ValueError) as exc:
        LinkSwitch("eth0; reboot")
    assert str(exc.value) == "radio.device must be a network interface name, not 'eth0; reboot'"
