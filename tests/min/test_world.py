"""The 2-D world (esair_min.world): rooms, rays, the body's integration, lag, slip and
wall contact."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from esair_min.errors import ConfigError
from esair_min.world import Landmark, Pose, Room, Segment, World, WorldOptions, load_room

ROOMS = Path("tests/fixtures/rooms")


def test_default_room_is_a_5_m_box():
    room = Room.default()
    assert room.bounds() == (0.0, 0.0, 5000.0, 5000.0)
    assert room.clearance(2500, 1000) == 1000.0
    assert room.ray(2500, 2500, 0.0) == 2500.0
    assert room.ray(2500, 2500, math.pi / 2) == pytest.approx(2500.0)


def test_load_room_walls_and_landmarks():
    room = load_room(ROOMS / "lab.yaml")
    assert len(room.walls) == 5 and room.walls[4] == Segment(3000, 0, 3000, 1500)
    assert room.landmarks == (Landmark("speaker", 5500, 3500, "sound"),
                              Landmark("poster", 0, 2000, "mark"))
    assert room.ray(1000, 1000, 0.0) == 2000.0          # the pillar wall
    assert room.ray(1000, 2000, 0.0) == 5000.0          # above it: the far wall


@pytest.mark.parametrize("name, message", [
    ("bad_box", "'box' is [width, depth] in mm"),
    ("unknown_key", "unknown key 'doors' in a room file (allowed: box, walls, landmarks)"),
    ("short_wall", "wall 0 is [x0, y0, x1, y1] in mm"),
    ("no_walls", "a room needs walls: give 'box' or 'walls'"),
    ("nan_box", "'box' must be a finite number of mm, not nan"),
])
def test_bad_room_files(name, message):
    with pytest.raises(ConfigError) as exc:
        load_room(ROOMS / f"{name}.yaml")
    assert str(exc.value) == f"tests/fixtures/rooms/{name}.yaml:1:1: {message}"


def test_straight_and_turning_motion():
    w = World(pose=Pose(1000, 1000, 0))
    for _ in range(100):
        w.step(0.01, 500, 0, 0)
    assert (w.pose.x, w.pose.y) == pytest.approx((1500, 1000))
    w.pose = Pose(1000, 1000, math.pi / 2)              # forward is +y now
    for _ in range(100):
        w.step(0.01, 0, 200, 0)                          # to the robot's left: -x
    assert (w.pose.x, w.pose.y) == pytest.approx((800, 1000))
    for _ in range(100):
        w.step(0.01, 0, 0, math.pi / 2)
    assert w.pose.theta == pytest.approx(math.pi)
    assert w.t_s == pytest.approx(3.0) and w.collisions == 0


def test_a_wall_stops_the_body_at_its_radius():
    w = World(pose=Pose(4000, 2500, 0), options=WorldOptions(radius_mm=150))
    steps = [w.step(0.01, 1000, 0, 0) for _ in range(200)]
    assert w.pose.x == pytest.approx(5000 - 150, abs=0.01)
    first = next(i for i, s in enumerate(steps) if s.collided)
    assert first == 85                                  # 850 mm at 10 mm a step
    assert all(s.collided for s in steps[first:]) and w.collisions == 1
    assert w.velocity == (0.0, 0.0, 0.0)
    back = w.step(0.01, -1000, 0, 0)                    # away from the wall: free again
    assert not back.collided and w.pose.x == pytest.approx(4840, abs=0.01)


def test_lag_and_slip():
    lag = World(pose=Pose(1000, 1000, 0), options=WorldOptions(lag_s=0.1))
    lag.step(0.1, 1000, 0, 0)
    assert lag.velocity[0] == pytest.approx(1000 * (1 - math.exp(-1)))
    slip = World(pose=Pose(1000, 1000, 0), options=WorldOptions(slip=0.1))
    for _ in range(100):
        slip.step(0.01, 1000, 0, 0)
    assert slip.pose.x == pytest.approx(1900)
    noisy = [World(pose=Pose(1000, 1000, 0), options=WorldOptions(slip_noise=0.05, seed=s))
             for s in (1, 1, 2)]
    for w in noisy:
        for _ in range(50):
            w.step(0.01, 1000, 0, 0)
    assert noisy[0].pose == noisy[1].pose != noisy[2].pose


def test_pose_to_world_and_step_needs_time():
    p = Pose(100, 200, math.pi / 2)
    assert p.to_world(10, 0) == pytest.approx((100, 210))
    with pytest.raises(ValueError, match="a step needs a time above 0 s, not 0"):
        World().step(0, 1, 0, 0)
