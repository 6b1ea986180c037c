"""STARFISH emulated in its room (esair_min.emulator.starfish): a square driven by a
host, the flow odometry against the world's true pose, the watchdog stopping the robot,
a wall stopping it, a lifted flow sensor, and the trace."""

from __future__ import annotations

import pytest

from esair_min.components.omni_base.core import WATCHDOG_NOTICE, velocity_line
from esair_min.components.optical_flow.odometry import parse_odometry
from esair_min.emulator.starfish import FlowOptions, StarfishSim, drive_square
from esair_min.world import Pose, World


def test_square_with_exact_flow_sensors(starfish):
    sim = StarfishSim(starfish, World(pose=Pose(500, 500, 0)), FlowOptions(noise=0.0))
    run = drive_square(sim, 4000)
    assert (run.polls, run.refused, sim.world.collisions) == (1282, 0, 0)
    assert sim.now_s == pytest.approx(64.3)
    # Open loop, the robot does not close the square (the wheels' duties are quantized,
    # so it turns a little), but counts without noise follow it within 4 mm over 16 m.
    assert run.max_error_mm < 4.0 and run.end_error_mm < 2.0
    assert abs(run.true_end[2]) > 0.01
    rows = sim.trace
    assert len(rows) == 6436 and rows[-1].t_s == pytest.approx(64.3, abs=0.01)
    assert max(r.wheels[0] for r in rows) == pytest.approx(-min(r.wheels[0] for r in rows),
                                                           rel=0.05)


def test_square_with_noisy_flow_sensors_drifts_but_stays_near(starfish):
    sim = StarfishSim(starfish, World(pose=Pose(500, 500, 0)), FlowOptions(noise=0.02, seed=1))
    run = drive_square(sim, 4000)
    assert 20.0 < run.end_error_mm < 250.0          # 2 % noise over 16 m: drift, bounded
    again = drive_square(StarfishSim(starfish, World(pose=Pose(500, 500, 0)),
                                     FlowOptions(noise=0.02, seed=1)), 4000)
    assert again == run                              # seeded: the same run twice


def test_watchdog_stops_the_robot_in_the_world(starfish):
    sim = StarfishSim(starfish, World(pose=Pose(1000, 2500, 0)))
    assert sim.command(velocity_line(300, 0, 0)) == "OK"
    sim.run_for(0.5)
    assert bytes(sim.notices) == b""
    sim.run_for(0.1)
    assert bytes(sim.notices) == WATCHDOG_NOTICE
    assert sim.i2c[-1][1:] == (0x30, bytes(7))
    sim.run_for(0.5)                                  # ramped down within 150 ms
    x = sim.world.pose.x
    assert sim.drive.rim_speeds() == [0.0, 0.0, 0.0]
    sim.run_for(5.0)
    assert sim.world.pose.x == x and bytes(sim.notices) == WATCHDOG_NOTICE


def test_a_wall_stops_the_robot(starfish):
    sim = StarfishSim(starfish, World(pose=Pose(4000, 2500, 0)))
    for _ in range(60):                               # 3 s at 400 mm/s toward x = 5000
        assert sim.command(velocity_line(400, 0, 0)) == "OK"
        sim.run_for(0.05)
    assert sim.world.pose.x == pytest.approx(5000 - 150, abs=0.5)
    assert sim.world.collisions == 1
    assert any(r.collided for r in sim.trace) and sim.trace[-1].collided


def test_lifted_flow_sensor_reports_no_surface(starfish):
    sim = StarfishSim(starfish, World(pose=Pose(1000, 2500, 0)), FlowOptions(noise=0.0))
    sim.sensors[0].lifted = True
    for _ in range(20):
        sim.command(velocity_line(200, 0, 0))
        sim.run_for(0.05)
    seq, sensors = parse_odometry(sim.command("O"))
    assert seq == 100
    assert sensors[0] == (0, 0, 0)                    # lifted: no counts, SQUAL 0
    assert sensors[1][2] == 90 and sensors[1][0] > 2500
    assert sim.sensors[0].lost > 0
