"""STARFISH's turn profile (esair_std/drivers/starfish/turn.py) against the emulated
drive board (esair_min's StarfishSim, on its virtual clock): a turn commanded at the
board files' top rate and stopped when RampModel says the ramp down ends at the goal
never turns faster than max_omega_mrad_s nor speeds up faster than the drive board's
ramp, comes to rest on its goal, and takes the profile's time (issue 37 item 4)."""

from __future__ import annotations

import math

import pytest

from esair_min.components.omni_base.core import velocity_line
from esair_min.emulator.starfish.robot_sim import FlowOptions, StarfishSim
from esair_min.emulator.uart import byte_time_ns
from esair_min.model.validate import load_robot
from esair_min.resources import resolve_robot
from esair_min.world import Pose, World
from esair_std.drivers.starfish.turn import RampModel, profile_time, stop_time, turn_limits


@pytest.fixture(scope="module")
def robot():
    return load_robot(resolve_robot("starfish"))


def test_the_limits_are_the_board_files(robot):
    omega, accel = turn_limits(robot)
    assert omega == robot.central.base.max_omega_mrad_s / 1000
    motor = robot.board("drive").motors[0]
    assert accel == pytest.approx(motor.ramp_mm_s2 / motor.mount_radius_mm)


@pytest.mark.parametrize("deg", [12, 40, 95, 175])
def test_a_turn_stopped_by_the_ramp_model_rests_on_its_goal_within_the_limits(robot, deg):
    omega, accel = turn_limits(robot)
    tick = robot.central.timer2.period_s
    sim = StarfishSim(robot, World(pose=Pose(3000, 2000, 0.0)), FlowOptions(noise=0.0))
    goal = math.radians(deg)
    model = RampModel(accel)
    go = velocity_line(0, 0, round(omega * 1000))
    # a line takes effect once its last byte is in: its characters' time on the wire
    byte_s = byte_time_ns(robot.central.uart.baud) / 1e9
    t_go = sim.now_s
    sim.command(go)
    model.command(t_go + (len(go) + 1) * byte_s, omega)
    stopped_at = None
    while stopped_at is None:                 # the host's loop: a command every 20 ms
        for _ in range(10):
            now = sim.now_s
            t = stop_time(model, 0.0, t_go, now, goal, 2 * byte_s, 0.002)
            if t is not None:
                stopped_at = now
                model.command(now + 2 * byte_s, 0.0)
                sim.command("x")
                break
            sim.run_for(0.002)
        else:
            sim.command(go)
        assert sim.now_s - t_go < 3.0
    sim.run_for(0.5)
    rows = [r for r in sim.trace if r.t_s >= t_go]
    turned = rows[-1].theta - rows[0].theta
    # rests on its goal: the stop's quantization (the host's 2 ms, the drive board's
    # 10 ms control tick) and the wheels' duties leave well under a degree
    assert abs(math.degrees(turned - goal)) < 1.0, math.degrees(turned)
    rates = [(b.theta - a.theta) / (b.t_s - a.t_s) for a, b in zip(rows, rows[1:])
             if b.t_s - a.t_s >= tick / 2]
    assert max(rates) <= omega * 1.02, max(rates)
    assert max(rates) >= min(omega, math.sqrt(goal * accel)) * 0.9
    # speeds up and slows down no faster than the ramp (over the control tick's steps)
    span = 5
    for a, b, c in zip(rows, rows[span:], rows[2 * span:]):
        r0 = (b.theta - a.theta) / (b.t_s - a.t_s)
        r1 = (c.theta - b.theta) / (c.t_s - b.t_s)
        assert abs(r1 - r0) / ((c.t_s - a.t_s) / 2) <= accel * 1.1
    # at rest within the profile's time (and a control tick or two of quantization)
    moving = [b.t_s for a, b in zip(rows, rows[1:]) if abs(b.theta - a.theta) > 1e-6]
    took = moving[-1] - t_go
    assert profile_time(goal, omega, accel) - 0.02 <= took <= profile_time(goal, omega, accel) + 0.03
    assert stopped_at is not None and model.at(stopped_at + 1.0)[1] == 0.0


def test_the_profile_is_time_optimal_within_the_limits(robot):
    omega, accel = turn_limits(robot)
    for deg in (5, 30, 60, 120, 180):
        a = math.radians(deg)
        t = profile_time(a, omega, accel)
        model = RampModel(accel)
        model.command(0.0, omega)
        # the stop sent at the last moment the ramp down can still end at the goal
        t_stop = stop_time(model, 0.0, 0.0, 0.0, a, 0.0, t)
        assert t_stop is not None
        model.command(t_stop, 0.0)
        angle, rate = model.at(t + 0.005)
        assert rate == 0.0 and angle == pytest.approx(a, abs=math.radians(0.3))
        samples = [model.at(k * 0.001)[1] for k in range(int(t * 1000) + 5)]
        assert max(samples) <= omega + 1e-9
        assert all(abs(y - x) <= accel * 0.001 + 1e-9 for x, y in zip(samples, samples[1:]))
        # no profile within the limits does it faster: a bang-bang at the limits
        assert t == pytest.approx(2 * math.sqrt(a / accel) if a < omega ** 2 / accel
                                  else a / omega + omega / accel)


@pytest.mark.parametrize("drive_deg", [0, 100, 230])
@pytest.mark.parametrize("sign", [1, -1])
def test_a_turn_started_while_driving_follows_the_wheel_by_wheel_ramp(robot, drive_deg, sign):
    """The robot drives at 200 mm/s (patrol's speed) when the turn is commanded: the
    drive board ramps each wheel toward its own rim speed, so the turn rate lags a turn
    from standing (the plain RampModel) until the drive has ramped out; WheelRamp, started
    from that drive command, tells where the robot is, and a turn stopped by it rests on
    its goal."""
    from esair_std.drivers.starfish.turn import WheelRamp
    omega, accel = turn_limits(robot)
    sim = StarfishSim(robot, World(pose=Pose(3000, 2000, 0.0)), FlowOptions(noise=0.0))
    a = math.radians(drive_deg)
    drive = (round(200 * math.cos(a)), round(200 * math.sin(a)))
    sim.command(velocity_line(drive[0], drive[1], 0))
    sim.run_for(0.5)                          # at the drive's speed
    th0 = sim.world.pose.theta
    wheel, plain = WheelRamp(robot, drive, sign), RampModel(accel)
    # the slow start (the flow sensors' limit), then the top rate: each model told when
    byte_s = byte_time_ns(robot.central.uart.baud) / 1e9
    for rate, hold in ((1.2, 0.12), (omega, 0.1)):
        line, t = velocity_line(0, 0, round(sign * rate * 1000)), sim.now_s
        sim.command(line)                     # (runs the clock to its reply)
        wheel.command(t + (len(line) + 1) * byte_s, rate)   # its last byte in
        plain.command(t + (len(line) + 1) * byte_s, rate)
        sim.run_for(hold - (sim.now_s - t))
    turned = sign * (sim.world.pose.theta - th0)
    # within the drive board's steps (its 10 ms control tick); the plain model runs ahead
    off_wheel = abs(math.degrees(wheel.at(sim.now_s)[0] - turned))
    off_plain = math.degrees(plain.at(sim.now_s)[0] - turned)
    assert off_wheel < 0.75 and off_plain > 1.5 and off_wheel < off_plain / 2, (off_wheel, off_plain)
    # stopped when WheelRamp says the ramp down ends at the goal: rests there
    goal = math.radians(60)
    t = stop_time(wheel, turned, sim.now_s, sim.now_s, goal, 2 * byte_s, 0.5)
    assert t is not None
    sim.run_for(t - sim.now_s)
    sim.command("x")
    t += 2 * byte_s
    sim.run_for(0.5)
    assert abs(math.degrees(sign * (sim.world.pose.theta - th0) - goal)) < 1.0
    assert wheel.rest(t) == pytest.approx(stop_angle(wheel, t))


def stop_angle(model, t):
    """The angle the model turns by once at rest when it is told the stop at ``t``."""
    model.command(t, 0.0)
    return model.at(t + 5.0)[0]


@pytest.mark.parametrize("late", [0.0, 0.15])
def test_the_standing_frame_is_known_by_the_ramp_model_and_a_late_stop_is_seen(robot, late):
    """Odometry frames every 50 ms (the example's 20 Hz) of a 90 deg turn whose stop
    lands on time, or 0.15 s late (a stalled computer): seen_at_rest takes the first
    frame read 20 ms after the model's rest when the stop was on time, and never a frame
    after which the robot still turned more than 0.1 deg (the late stop: the first
    frame past the model's rest is not taken)."""
    from esair_std.drivers.starfish.turn import seen_at_rest
    omega, accel = turn_limits(robot)
    sim = StarfishSim(robot, World(pose=Pose(3000, 2000, 0.0)), FlowOptions(noise=0.0))
    byte_s = byte_time_ns(robot.central.uart.baud) / 1e9
    th0 = sim.world.pose.theta

    grid = [sim.now_s]                        # the polls' times: every 50 ms, whatever else

    def frame():
        grid[0] += 0.05
        sim.run_for(grid[0] - sim.now_s)
        return sim.now_s, sim.world.pose.theta - th0

    model, goal = RampModel(accel), math.radians(90)
    line, t = velocity_line(0, 0, round(omega * 1000)), sim.now_s
    sim.command(line)
    model.command(t + (len(line) + 1) * byte_s, omega)
    frames = [(t, 0.0)]
    while (t_stop := stop_time(model, frames[-1][1], frames[-1][0], sim.now_s, goal,
                               2 * byte_s, 0.05)) is None:
        frames.append(frame())
        sim.command(line)                     # the rate again (the board's 0.5 s watchdog)
    anchor = frames[-1]
    while grid[0] + 0.05 < t_stop + late:      # the polls go on until the stop is sent
        frame()
        sim.command(line)
    sim.run_for(t_stop + late - sim.now_s)
    sim.command("x")
    landing = t_stop + 2 * byte_s              # where the model has the stop land
    stop_rate = model.at(landing)[1]
    model.command(landing, 0.0)
    rest_at = landing + stop_rate / accel
    prev, seen, first_past = anchor, None, None
    while seen is None:
        now = frame()
        if first_past is None and now[0] >= rest_at + 0.02:
            first_past = now
        if seen_at_rest(model, [anchor, prev, now], rest_at, stop_rate, 0.02, math.radians(0.1)):
            seen = now
        prev = now
        assert now[0] < rest_at + 1.0
    sim.run_for(0.5)
    rest = sim.world.pose.theta - th0
    assert abs(math.degrees(rest - seen[1])) <= 0.15            # it did stand there
    if not late:
        assert seen == first_past                               # no frame more
    else:
        assert math.degrees(rest - first_past[1]) > 1.0          # still turning then
        assert seen[0] > first_past[0]


def _on_tick(robot):
    """The landing of a line of ``nbytes`` sent at ``t`` for the ramp model: the drive
    board takes it at its first control tick (every CONTROL_TICK_MS of the emulator's
    clock) after the line's CR, the model's ramp half a tick before (the same speed in
    the middle of each tick)."""
    from esair_min.components.dc_motor.core import CONTROL_TICK_MS
    tick = CONTROL_TICK_MS / 1000
    byte_s = byte_time_ns(robot.central.uart.baud) / 1e9

    def landing(t: float, nbytes: int) -> float:
        return (math.ceil((t + (nbytes - 1) * byte_s) / tick - 1e-9) - 0.5) * tick
    return tick, byte_s, landing


@pytest.mark.parametrize("late_ticks", [0, 1, -1])
def test_a_stops_landing_is_fitted_from_a_frame_of_the_ramp_down(robot, late_ticks):
    """fit_stop: the stop landed on the drive board's tick the model has, a tick later or
    earlier (a slow or hasty host): an odometry frame 60 ms into the ramp down, carried
    from one read at the top rate, says when, to a millisecond, and rest_angle where the
    robot comes to rest, to 0.2 deg."""
    from esair_std.drivers.starfish.turn import WheelRamp, fit_stop, rest_angle
    omega, _ = turn_limits(robot)
    tick, byte_s, landing = _on_tick(robot)
    sim = StarfishSim(robot, World(pose=Pose(3000, 2000, 0.0)), FlowOptions(noise=0.0))
    sim.run_for(1.0)
    th0, t0 = sim.world.pose.theta, sim.now_s
    model = WheelRamp(robot)
    go = velocity_line(0, 0, round(omega * 1000))
    sim.command(go)
    model.command(landing(t0, len(go) + 2), omega)
    sim.run_for(1.3 - sim.now_s)
    anchor = (sim.now_s, sim.world.pose.theta - th0)     # on a tick: a frame's time
    send = 1.345
    sim.run_for(send + late_ticks * tick - sim.now_s)
    sim.command("x")
    told = landing(send, 3)
    model.command(told, 0.0)
    sim.run_for(told + 0.065 - sim.now_s)
    frame = (sim.now_s, sim.world.pose.theta - th0)
    t_land, inside = fit_stop(model, anchor, frame, 0.05)
    assert inside and t_land == pytest.approx(told + late_ticks * tick, abs=0.001)
    sim.run_for(0.5)
    assert abs(math.degrees(rest_angle(model, anchor) - (sim.world.pose.theta - th0))) < 0.2


@pytest.mark.parametrize("drive_deg", [0, 45, 135, 230, 300])
@pytest.mark.parametrize("sign", [1, -1])
def test_a_turn_started_while_driving_by_the_start_plan_loses_no_flow_count(robot, drive_deg, sign):
    """While patrol's drive (200 mm/s) ramps out wheel by wheel, a turn at the top rate
    takes a flow sensor past its top speed and the odometry loses counts: start_plan's
    start (a rate held, then the top; the behavior's START_LIMIT and START_MARGIN_S) loses
    none on the emulated boards, also with the top rate 30 ms early, and is no later than
    the fixed slow start (1.2 rad/s for 0.12 s) by 0.3 s."""
    from esair_std.drivers.starfish.turn import flow_limit, start_plan
    omega, _ = turn_limits(robot)
    top_ips, _ = flow_limit(robot)
    a = math.radians(drive_deg)
    drive = (round(200 * math.cos(a)), round(200 * math.sin(a)))
    rate, hold = start_plan(robot, drive, sign, omega, 0.75 * top_ips, 0.03)
    assert 0 < rate <= omega

    def turned(plan):
        sim = StarfishSim(robot, World(pose=Pose(3000, 2000, 0.0)), FlowOptions(noise=0.0))
        sim.command(velocity_line(drive[0], drive[1], 0))
        sim.run_for(0.5)
        th0, lost = sim.world.pose.theta, [s.lost for s in sim.sensors]
        t0 = sim.now_s
        for r, until in plan:
            sim.command(velocity_line(0, 0, round(sign * r * 1000)))
            sim.run_for(t0 + until - sim.now_s)
        return sign * (sim.world.pose.theta - th0), [s.lost - n for s, n in zip(sim.sensors, lost)]

    ahead, lost = turned([(rate, hold), (omega, 0.3)])
    assert lost == [0, 0]
    _, lost = turned([(rate, max(0.001, hold - 0.03)), (omega, 0.3)])    # the top rate early
    assert lost == [0, 0]
    fixed, _ = turned([(1.2, 0.12), (omega, 0.3)])
    assert ahead >= fixed - 1e-9
    top_at_once, lost_at_once = turned([(omega, 0.3)])
    assert rate < omega or lost_at_once == [0, 0]


@pytest.mark.parametrize("late_ms", [-25, 25, 60])
def test_a_stop_off_its_moment_is_corrected_while_the_robot_ramps_down(robot, late_ms):
    """The first stop lands 25 ms early, 25 or 60 ms late (a loaded host): the frame
    60 ms after it, fitted (fit_stop), says where the robot would rest; a creep on or back
    (the miss over 60 ms, at most 0.6 rad/s: TurnAndShoot's), commanded at once and
    stopped when the model says (stop_time), brings it to rest within 0.5 deg of its
    goal (the creep's stop lands on the drive board's next tick: 10 ms at 0.6 rad/s),
    before it ever stood."""
    from esair_std.drivers.starfish.turn import WheelRamp, fit_stop, rest_angle
    omega, _ = turn_limits(robot)
    tick, byte_s, landing = _on_tick(robot)
    sim = StarfishSim(robot, World(pose=Pose(3000, 2000, 0.0)), FlowOptions(noise=0.0))
    sim.run_for(1.0)
    th0, t0, goal = sim.world.pose.theta, sim.now_s, math.radians(90)
    model = WheelRamp(robot)
    go = velocity_line(0, 0, round(omega * 1000))
    sim.command(go)
    model.command(landing(t0, len(go) + 2), omega)
    sim.run_for(1.2 - sim.now_s)
    anchor = (sim.now_s, sim.world.pose.theta - th0)
    t_stop = stop_time(model, anchor[1], anchor[0], sim.now_s, goal, 2 * byte_s, 0.5)
    told = landing(t_stop, 3)
    sim.run_for(t_stop + late_ms / 1000 - sim.now_s)
    sim.command("x")
    model.command(told, 0.0)
    sim.run_for(told + late_ms / 1000 + 0.06 - sim.now_s)
    frame = (sim.now_s, sim.world.pose.theta - th0)
    t_land, inside = fit_stop(model, anchor, frame, 0.2)
    assert inside
    err = goal - rest_angle(model, anchor)
    assert abs(math.degrees(err)) > 1.5                 # a miss worth the correction
    rate = min(0.6, max(0.25, abs(err) / 0.06)) * (1 if err > 0 else -1)
    line, t = velocity_line(0, 0, round(rate * 1000)), sim.now_s
    sim.command(line)
    model.command(landing(t, len(line) + 2), rate)
    now = sim.now_s
    t2 = stop_time(model, frame[1], frame[0], now, goal, 2 * byte_s, 0.4, back=err < 0)
    assert t2 is not None
    sim.run_for(t2 - sim.now_s)
    sim.command("x")
    sim.run_for(0.5)
    assert abs(math.degrees(sim.world.pose.theta - th0 - goal)) < 0.5


@pytest.mark.parametrize("name, commands, stop_after", [
    # a short turn (20 deg) stopped on its way up to the top rate (a triangle)
    ("short turn", [(0.0, (0, 0, 3000))], 0.11),
    ("slow start", [(0.0, (0, 0, 1200)), (0.12, (0, 0, 3000))], 0.2),
    ("top rate", [(0.0, (0, 0, 3000))], 0.5),
    ("drive ramping in", [(0.0, (200, 0, 0))], 0.05),
    ("drive reversed", [(0.0, (200, 0, 0)), (0.4, (-200, 0, 0))], 0.46),
])
def test_the_wheels_say_when_they_rest_after_a_stop_at_the_latest(robot, monkeypatch, name,
                                                                  commands, stop_after):
    """The Wheels actuator's ``at_rest`` after a stop (the driver's extra odometry poll)
    is never before the emulated drive board's wheels stand, and within two of its
    control ticks of it; a turn stopped on its way up is told by the ramp from the
    commands written, not by the speed last commanded (a tick or more sooner)."""
    from esair_std.drivers.starfish import omnilink
    from esair_std.drivers.starfish.omniboard import omni_of
    sim = StarfishSim(robot, World(pose=Pose(3000, 2000, 0.0)), FlowOptions(noise=0.0))
    sim.keep_trace = True
    monkeypatch.setattr(omnilink, "time", type("Clock", (), {"monotonic": lambda: sim.now_s}))
    told: list[float] = []
    wheels = omnilink.Wheels(None, 600, 3000, omni_of(robot), told.append)  # type: ignore[arg-type]
    monkeypatch.setattr(wheels, "_send", lambda line: sim.command(line))
    t0 = sim.now_s
    for at, (vx, vy, w) in commands:
        sim.run_until(round((t0 + at) * 1e9))
        wheels.write({"vx": vx, "vy": vy, "w": w})
    sim.run_until(round((t0 + stop_after) * 1e9))
    last = wheels.last
    wheels.write("stop")
    replied = sim.now_s
    sim.run_for(0.6)
    moving = [r.t_s for r in sim.trace if any(r.wheels)]
    standing = [r.t_s for r in sim.trace if r.t_s > moving[-1]]
    tick = omni_of(robot).control_tick_s
    assert len(told) == 1 and moving[-1] <= told[0] <= standing[0] + 2 * tick, (told, moving[-1])
    # the speed last commanded: the bound before the ramp was followed
    step = min(row[3] for row in omni_of(robot).drive)
    commanded = max(abs(r[0] * last[0] + r[1] * last[1] + r[2] * last[2] / 1000)
                    for r in omni_of(robot).drive)
    if name == "short turn":
        assert told[0] <= replied + (math.ceil(commanded / step) - 5) * tick + 1e-9
