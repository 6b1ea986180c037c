"""STARFISH's omni link commands, radio model, path planner and link switch
(esair_std/drivers/starfish/)."""

import sys

import pytest

from esair_std.drivers.starfish.linkswitch import LinkSwitch
from esair_std.drivers.starfish.planner import NoPath, plan
from esair_std.drivers.starfish.radio import RadioModel
from tests.support.starfish_comps import example_scene
from tests.support.std import wait_for


def test_the_omni_commands_match_replies_by_shape_and_check_the_robot():
    from esair_min.model.validate import load_robot
    from esair_min.resources import resolve_robot
    from esair_std.drivers.minlink.link_errors import LinkError
    from esair_std.drivers.starfish.omnilink import OmniCommands, omni_budget

    robot = load_robot(resolve_robot("starfish"))
    c = OmniCommands(robot)
    assert [c.prefix(a) for a in ("velocity", "odometry", "stop", "version")] == ["V", "O", "x", "v"]
    assert c.plausible("O", "n=3 a=1,2,90 b=3,4,90") and not c.plausible("O", "")
    assert c.plausible("V+0100+0000+0000", "") and not c.plausible("x", "n=3 a=1,2,90 b=3,4,90")
    assert c.plausible("v", "esair-min/1 starfish wheels=3") and not c.plausible("v", "")
    c.check_version("esair-min/1 starfish wheels=3 flow=2 watchdog=500 checksum=off id=0badcafe")
    with pytest.raises(LinkError) as exc:
        c.check_version("esair-min/1 papaman servos=8 sensors=8 motions=4 image=ok checksum=off")
    assert str(exc.value) == (f"the robot answers wheels=? but the board files of starfish say "
                              f"wheels=3 ({robot.source})")
    # the longest O reply at 38400 baud: 19.5 ms an exchange, 25.6 a second in half the line
    assert robot.central.uart.baud == 38400
    assert round(omni_budget(robot).feet_exchange_s * 1e3, 1) == 19.5
    assert round(omni_budget(robot).max_feet_hz(0.5), 1) == 25.6


def test_the_radio_is_cut_out_of_range_and_behind_a_wall_and_heals_inside_the_edge():
    radio = RadioModel(example_scene(access_point=(1.0, 1.0)), range_m=3.0, heal_m=0.1)
    assert radio.update(3.9, 1.0 + 0.0)["up"] is False            # behind the inner wall
    assert radio.update(2.0, 3.0) == {"up": True, "distance": 2.236, "los": True}
    assert radio.update(3.1, 3.2)["up"] is False                  # 3.04 m: out of range
    assert radio.update(2.95, 3.2)["up"] is False                 # 2.94 m: not yet healed
    assert radio.update(2.85, 3.2)["up"] is True                  # 2.87 m
    assert radio.cuts == 2


def test_the_planner_goes_around_the_inner_wall():
    room = example_scene()
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
    from esair_min.world import Room, Segment
    from esair_std.drivers.starfish.scene import from_world
    room = from_world(Room(Room.box(6000, 4000).walls + (Segment(3000, 0, 3000, 4000),)))
    with pytest.raises(NoPath) as exc:
        plan(room, (4.5, 1.0), (1.0, 1.0), margin=0.25)
    assert str(exc.value) == "no path from (4.50, 1.00) to (1.00, 1.00) keeps 0.25 m from the walls"


def test_the_link_switch_runs_ip_for_the_newest_wanted_state(tmp_path):
    log = tmp_path / "ip.log"
    fake_ip = (sys.executable, "-c",
               f"import sys; open({str(log)!r}, 'a').write(' '.join(sys.argv[1:]) + chr(10))")
    sw = LinkSwitch("eth9", command=fake_ip, owned=lambda dev: None)   # the worker alone
    sw.set(True)
    wait_for(lambda: sw.applied is True, 20, "the link up")
    sw.set(False)
    wait_for(lambda: sw.applied is False, 20, "the link down")
    sw.close()
    assert log.read_text().splitlines() == ["eth9 up", "eth9 down"] and sw.failures == 0


def test_a_failing_ip_is_counted_with_its_message():
    sw = LinkSwitch("eth9", command=(sys.executable, "-c", "import sys; sys.exit('no such device')"),
                    owned=lambda dev: None)
    sw.set(False)
    wait_for(lambda: sw.failures >= 1, 20, "a failure")
    sw.close()
    assert sw.last_error == "no such device" and sw.applied is None
    with pytest.raises(ValueError) as exc:
        LinkSwitch("eth0; reboot")
    assert str(exc.value) == "radio.device must be a network interface name, not 'eth0; reboot'"


def test_a_room_of_starfishs_emulated_world_converts_to_metres_and_kinds():
    from esair_min.world import Landmark
    from esair_min.world import Room as WorldRoom
    from esair_std.drivers.starfish.scene import from_world as from_world_room
    world = WorldRoom.box(6000, 4000, landmarks=(Landmark("bell", 1000, 3500, "sound"),
                                                 Landmark("ap", 1000, 1000, "access_point"),
                                                 Landmark("pole", 5600, 400)))
    room = from_world_room(world)
    assert room.walls.tolist() == [[0, 0, 6, 0], [6, 0, 6, 4], [6, 4, 0, 4], [0, 4, 0, 0]]
    assert room.source.to_dict() == {"x": 1.0, "y": 3.5, "on": False, "level": 0.1}
    assert room.access_point == (1.0, 1.0)
    assert [(lm["x"], lm["y"]) for lm in room.landmarks] == [(5.6, 0.4)]
