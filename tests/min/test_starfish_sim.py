"""STARFISH emulated in its room (esair_min.emulator.starfish.robot_sim): a square driven by a
host, the flow odometry against the world's true pose, the watchdog stopping the robot,
a wall stopping it, a lifted flow sensor, and the trace."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from esair_min.components.omni_base.core import WATCHDOG_NOTICE, velocity_line
from esair_min.components.optical_flow.odometry import parse_odometry
from esair_min.emulator.starfish.robot_sim import I2C_KEEP, FlowOptions, StarfishSim, drive_square
from esair_min.emulator.uart import byte_time_ns
from esair_min.model.validate import load_robot
from esair_min.world import Pose, World

ROOT = Path(__file__).resolve().parents[2]

VERSION = "OK esair-min/1 starfish wheels=3 flow=2 watchdog=500 checksum=off"


def test_square_with_exact_flow_sensors(starfish):
    sim = StarfishSim(starfish, World(pose=Pose(500, 500, 0)), FlowOptions(noise=0.0))
    run = drive_square(sim, 4000)
    assert (run.polls, run.refused, sim.world.collisions) == (1282, 0, 0)
    # 64.3 s of periods, plus the odometry polls' time on the line before the first
    # period and after the last (the line at 38400 baud: 3 bytes out, 37 back)
    line = (3 + 37) * 10 / 38400
    assert sim.now_s == pytest.approx(64.3 + 2 * line, abs=0.004)
    # Open loop, the robot does not close the square (the wheels' duties are quantized,
    # so it turns a little), but counts without noise follow it within 4 mm over 16 m.
    assert run.max_error_mm < 4.0 and run.end_error_mm < 2.0
    assert abs(run.true_end[2]) > 0.01
    rows = sim.trace
    assert len(rows) == 6438 and rows[-1].t_s == pytest.approx(64.3 + 2 * line, abs=0.01)
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
    # 20 x (50 ms + the V line and its OK on the line: 22 bytes at 38400 baud, 5.7 ms)
    # and the O line's 3 bytes: 1.115 s of 9.99 ms ticks
    assert seq == 111
    assert sensors[0] == (0, 0, 0)                    # lifted: no counts, SQUAL 0
    assert sensors[1][2] == 90 and sensors[1][0] > 2500
    assert sim.sensors[0].lost > 0


def _at_baud(robot, baud: int):
    central = robot.central
    boards = tuple(b.model_copy(update={"uart": central.uart.model_copy(update={"baud": baud})})
                   if b is central else b for b in robot.boards)
    return dataclasses.replace(robot, boards=boards)


@pytest.mark.parametrize("baud", [38400, 9600])
def test_a_reply_arrives_at_the_pace_of_the_board_files_baud(starfish, baud):
    """The line is PAPA-MAN's (esair_min.emulator.uart): a command is decoded when its
    last byte has arrived, and its reply reaches the host one byte every 10 bit times of
    the board file's baud, counted on the virtual clock."""
    robot = starfish if baud == 38400 else _at_baud(starfish, baud)
    assert robot.central.uart.baud == baud
    sim = StarfishSim(robot, World(pose=Pose(1000, 2500, 0)))
    sim.settle()
    assert sim.read() == b"!READY esair-min/1 starfish\r\n"
    byte = byte_time_ns(baud)
    reply = (VERSION + "\r\n").encode()
    t0 = sim.clock.now
    sim.write(b"v\r\n")
    got = bytearray()
    # the CR is complete after 2 byte times; the k-th byte of the reply k byte times later
    for k in range(len(reply) + 1):
        sim.run_until(t0 + (2 + k) * byte - 1)
        got += sim.read()
        assert len(got) == max(0, k - 1)
        sim.run_until(t0 + (2 + k) * byte)
        got += sim.read()
        assert len(got) == k
    assert bytes(got) == reply
    sim.run_for(0.1)
    assert sim.read() == b""


@pytest.mark.parametrize("name", ["starfish", "starfish-avr"])
def test_the_boot_notice_names_the_robot_emulated(name):
    """`!READY esair-min/1 <robot>` at reset, the robot's name as in its `v` reply."""
    robot = load_robot(ROOT / "boards" / name)
    sim = StarfishSim(robot, World(pose=Pose(1000, 2500, 0)))
    sim.settle()
    assert sim.read() == f"!READY esair-min/1 {name}\r\n".encode()
    sim.write(b"v\r\n")
    sim.settle()
    assert sim.read().startswith(f"OK esair-min/1 {name} wheels=3 ".encode())


def test_lines_faster_than_their_replies_overrun_the_ring(starfish):
    """A host sending lines with long replies back to back outruns the replies: the
    superloop waits for transmit room, the 64-byte ring fills and bytes are lost; the
    next line that gets in is answered E12 (docs/protocol.md, Lines), as on PAPA-MAN."""
    sim = StarfishSim(starfish, World(pose=Pose(1000, 2500, 0)))
    sim.settle()
    sim.read()
    sim.uart.dropped = []
    sim.write(b"v\r\n" * 40)                 # 120 bytes in, 40 x 67 bytes of replies
    sim.run_for(1.0)
    sim.write(b"v\r\n")
    sim.run_for(0.1)
    # 24 lines answered; bytes 72..119 (the last 16 lines) found the ring full
    assert sim.read().decode().splitlines() == [VERSION] * 24 + ["E12 input overrun"]
    assert sim.uart.overruns == 48 and sim.uart.dropped == list(range(72, 120))


def test_the_record_of_drive_writes_is_bounded_and_counts_what_it_dropped(starfish):
    """``i2c`` keeps the latest ``i2c_keep`` writes to the drive board (every velocity
    line is one), ``i2c_writes`` counts them all and ``i2c_dropped`` the ones let go; the
    writes kept are the last ones an unbounded record has."""
    small = StarfishSim(starfish, World(pose=Pose(1000, 2500, 0)), i2c_keep=8)
    whole = StarfishSim(starfish, World(pose=Pose(1000, 2500, 0)), i2c_keep=100)
    for sim in (small, whole):
        for k in range(12):
            assert sim.command(velocity_line(10 * k, 0, 0)) == "OK"
            sim.run_for(0.05)
    assert (small.i2c_writes, len(small.i2c), small.i2c_dropped) == (12, 8, 4)
    assert (whole.i2c_writes, len(whole.i2c), whole.i2c_dropped) == (12, 12, 0)
    assert list(small.i2c) == list(whole.i2c)[-8:]
    assert StarfishSim(starfish).i2c.maxlen == I2C_KEEP == 1024
