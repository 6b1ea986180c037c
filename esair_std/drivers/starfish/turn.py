"""STARFISH's turn in place at its physical limits (docs/std-starfish.md, "the shot").

The board files set the limits: the central board's ``max_omega_mrad_s`` and each
wheel's ``limit_mm_s`` cap the turn rate, the drive board's ``ramp_mm_s2`` over the
wheels' ``mount_radius_mm`` the angular acceleration (the board ramps every wheel toward
its commanded speed by that much each control tick). A turn commanded at the top rate
and stopped at the right moment follows the time-optimal profile (trapezoid, or triangle
when too short to reach the top rate): the board's own ramp speeds it up and slows it
down. :class:`RampModel` replays the commands through that ramp, so the behavior can
predict where the robot will come to rest if it stops now. Pure computation, on the
robot's plain facts (omniboard.OmniBoard; esair_min's model is made into them).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pragma: no cover
    from .omniboard import OmniBoard


def turn_limits(robot: Any) -> tuple[float, float]:
    """(top turn rate rad/s, angular acceleration rad/s^2) of an omni base's robot
    (:class:`~.omniboard.OmniBoard`, or esair_min's model): the smallest the central
    board and every wheel allow."""
    omni = _omni(robot)
    omega = min([omni.max_omega_mrad_s / 1000.0] +
                [m.limit_mm_s / m.mount_radius_mm for m in omni.motors])
    accel = min(m.ramp_mm_s2 / m.mount_radius_mm for m in omni.motors)
    return omega, accel


def _omni(robot: Any) -> "OmniBoard":
    """The robot's plain facts (omniboard.py), the turn's limits among them."""
    from .omniboard import omni_of
    omni = omni_of(robot)
    if not omni.has_turn:
        raise ValueError("the robot's prepared board facts hold no turn limits (the "
                         "wheels' limits and ramps): prepare them again (omniboard.py)")
    return omni


def wheel_radius(robot: Any) -> float:
    """The wheels' largest distance from the centre (mm)."""
    return float(max(m.mount_radius_mm for m in _omni(robot).motors))


def max_speed(robot: Any) -> float:
    """The base's top drive speed (mm/s)."""
    return float(_omni(robot).max_speed_mm_s)


def flow_limit(robot: Any) -> tuple[float, float]:
    """(the flow sensors' top speed mm/s, their largest distance from the centre mm): a
    sensor moving faster loses counts, and the odometry its heading."""
    omni = _omni(robot)
    return omni.flow_max_mm_s, max(math.hypot(f.mount_x_mm, f.mount_y_mm) for f in omni.flow)


def profile_time(angle: float, omega: float, accel: float) -> float:
    """The shortest time (s) to turn ``angle`` rad from standing to standing."""
    a = abs(angle)
    if a >= omega * omega / accel:
        return a / omega + omega / accel
    return 2.0 * math.sqrt(a / accel)


class RampModel:
    """The turn rate the drive board's ramp gives for the commands sent: ``command(t,
    rate)`` records a commanded rate (rad/s, >= 0 in the turn's direction) from time t;
    ``at(t)`` is (angle turned since the first command, rate) at time t."""

    def __init__(self, accel: float):
        self.accel = accel
        self.changes: list[tuple[float, float]] = []

    def command(self, t: float, rate: float) -> None:
        while self.changes and self.changes[-1][0] >= t:     # a later plan replaced
            self.changes.pop()
        if not self.changes or self.changes[-1][1] != rate:
            self.changes.append((t, rate))

    def at(self, t: float) -> tuple[float, float]:
        angle = speed = 0.0
        for i, (t0, target) in enumerate(self.changes):
            if t <= t0:
                break
            t1 = min(t, self.changes[i + 1][0]) if i + 1 < len(self.changes) else t
            angle, speed = _ramp(angle, speed, target, self.accel, t1 - t0)
        return angle, speed

    def rest(self, t: float) -> float:
        """The angle turned once at rest, the stop landing at time t."""
        angle, rate = self.at(t)
        return angle + rate * abs(rate) / (2 * self.accel)


class WheelRamp(RampModel):
    """:class:`RampModel` wheel by wheel: the drive board ramps each wheel toward its own
    rim speed at its ``ramp_mm_s2``. A robot that was driving (``drive``: vx, vy mm/s,
    its frame) starts from that drive's rim speeds, and while they ramp out its turn rate
    lags a turn from standing (a wheel already past its turn speed slows down while the
    others speed up). ``sign``: the turn's direction (rates and angles in it, >= 0)."""

    def __init__(self, robot: Any, drive: tuple[float, float] = (0.0, 0.0), sign: float = 1.0,
                 rims: list[float] | None = None):
        omni = _omni(robot)
        motors = omni.motors
        super().__init__(min(m.ramp_mm_s2 / m.mount_radius_mm for m in motors))
        self.rows = [row[:3] for row in omni.drive]     # (vx, vy, omega) -> rim speeds
        self.inv = omni.inverse                         # rim speeds -> (vx, vy, omega)
        self.omega_row = self.inv[2]
        self.ramps = [float(m.ramp_mm_s2) for m in motors]
        # each wheel's rim speed when the first command lands: the drive's, or ``rims``
        # (mm/s) where the wheels are still ramping toward it
        self.start = [sign * (r[0] * drive[0] + r[1] * drive[1]) for r in self.rows] \
            if rims is None else [sign * v for v in rims]

    def _wheels(self, t: float) -> list[tuple[float, float]]:
        """Each wheel's (rim travel mm, rim speed mm/s) at time t."""
        out = []
        for i, row in enumerate(self.rows):
            dist, speed = 0.0, self.start[i]
            for k, (t0, rate) in enumerate(self.changes):
                if t <= t0:
                    break
                t1 = min(t, self.changes[k + 1][0]) if k + 1 < len(self.changes) else t
                dist, speed = _ramp(dist, speed, row[2] * rate, self.ramps[i], t1 - t0)
            out.append((dist, speed))
        return out

    def body(self, t: float) -> tuple[float, float, float]:
        """The body's velocity at time t: vx, vy mm/s (its frame), omega rad/s (all in
        the turn's direction)."""
        v = [speed for _, speed in self._wheels(t)]
        vx, vy, w = (sum(c * x for c, x in zip(row, v)) for row in self.inv)
        return vx, vy, w

    def at(self, t: float) -> tuple[float, float]:
        w = self._wheels(t)
        return (sum(c * d for c, (d, _) in zip(self.omega_row, w)),
                sum(c * v for c, (_, v) in zip(self.omega_row, w)))

    def rest(self, t: float) -> float:
        w = self._wheels(t)
        return sum(c * (d + v * abs(v) / (2 * a))
                   for c, (d, v), a in zip(self.omega_row, w, self.ramps))


def start_plan(robot: Any, drive: tuple[float, float], sign: float, top: float,
               limit: float, margin: float = 0.0) -> tuple[float, float]:
    """How a turn starts while the robot drives (``drive``: vx, vy mm/s, its frame): a
    rate held for a while, then ``top``, so that no flow sensor moves faster than
    ``limit`` mm/s while the drive ramps out wheel by wheel (WheelRamp), also when the
    top rate lands up to ``margin`` s sooner after the first. Of the rates from ``top``
    down to 40 % of it, each with the shortest hold (20 ms steps, 0.2 s at most) that
    keeps them under, the one that has turned furthest at 0.25 s: (rate, hold); (top,
    0.0) when the top rate keeps them under at once, (0.0, 0.0) when none does."""
    robot = _omni(robot)
    sensors = [(float(f.mount_x_mm), float(f.mount_y_mm)) for f in robot.flow]
    probe = WheelRamp(robot, drive, sign)
    ramp_out = max(abs(s) / a for s, a in zip(probe.start, probe.ramps)) + 0.02
    times = [0.005 + 0.01 * k for k in range(int(ramp_out / 0.01) + 1)]

    def fast(model: WheelRamp) -> bool:
        for t in times:
            vx, vy, w = model.body(t)
            if any(math.hypot(vx - w * py, vy + w * px) > limit for px, py in sensors):
                return True
        return False

    best, plan = -1.0, (0.0, 0.0)
    for k in range(7):
        rate = top * (1.0 - 0.1 * k)
        for hold in ([0.0] if k == 0 else [0.02 * j for j in range(1, 11)]):
            model = WheelRamp(robot, drive, sign)
            model.command(0.0, rate)
            if hold:
                model.command(max(1e-3, hold - margin), top)
            if not fast(model):
                model.changes = model.changes[:1]
                if hold:
                    model.command(hold, top)
                ahead = model.at(0.25)[0]
                if ahead > best:
                    best, plan = ahead, (rate, hold)
                break
        if k == 0 and best >= 0:
            return plan
    return plan


def _ramp(angle: float, speed: float, target: float, accel: float, dt: float) -> tuple[float, float]:
    """Angle and rate after ``dt`` s of ramping from ``speed`` toward ``target``."""
    reach = abs(target - speed) / accel
    step = math.copysign(accel, target - speed)
    if dt <= reach:
        return angle + speed * dt + 0.5 * step * dt * dt, speed + step * dt
    return angle + speed * reach + 0.5 * step * reach * reach + target * (dt - reach), target


def stop_time(model: RampModel, angle_then: float, t_then: float, now: float, goal: float,
              latency: float, horizon: float, back: bool = False) -> float | None:
    """The first time in [now, now + horizon] at which a stop sent (arriving ``latency``
    s later) brings the robot to rest at ``goal`` rad: ``angle_then`` was measured at
    ``t_then`` (odometry), the model carries it on; None if not within the horizon.
    ``back``: the robot turns back (a negative rate), toward a goal behind it."""
    base = model.at(t_then)[0]

    def reaches(t: float) -> bool:
        rest = angle_then + model.rest(t + latency) - base
        return rest <= goal if back else rest >= goal

    if reaches(now):
        return now
    n = max(1, int(horizon / 0.002))
    for k in range(1, n + 1):
        t = now + horizon * k / n
        if reaches(t):
            # the moment within the last 2 ms step, to a few microseconds (at the top
            # rate a whole step would be a third of a degree)
            lo = t - horizon / n
            for _ in range(10):
                mid = (lo + t) / 2
                lo, t = (lo, mid) if reaches(mid) else (mid, t)
            return t
    return None


def seen_at_rest(model: RampModel, frames: list[tuple[float, float]], rest_at: float,
                 stop_rate: float, margin: float, left: float, back: bool = False) -> bool:
    """Does the odometry frame ``frames[-1]`` (time, angle turned) see the robot at
    rest, the stop told to ``model``? It was read at least ``margin`` s after the
    model's rest ``rest_at``, and since each earlier frame in ``frames`` (the one the
    stop was planned from, the one before it) it turned no more than the model says
    beyond what a stop landing that much late (the excess over ``stop_rate``, the rate
    it stopped from) would still have to turn after it: ``left`` rad at most.
    ``back``: it stopped from turning back (a late stop turns it further back)."""
    t, turned = frames[-1]
    if t < rest_at + margin:
        return False
    for t0, a0 in frames[:-1]:
        extra = turned - a0 - (model.at(t)[0] - model.at(t0)[0])
        extra = -extra if back else extra
        late = max(0.0, extra) / max(stop_rate, 0.05)
        if 0.5 * model.accel * max(0.0, late - (t - rest_at)) ** 2 > left:
            return False
    return True


def fit_stop(model: RampModel, anchor: tuple[float, float], frame: tuple[float, float],
             spread: float) -> tuple[float, bool]:
    """When the stop (``model``'s last command, a rate of 0) landed, from the odometry:
    the landing within ``spread`` s of the model's that carries the angle turned at
    ``anchor`` (time, angle; before the stop) on to the one ``frame`` read after it.
    Sets it in ``model`` and returns (it, whether it lies inside the window: False when
    the frame asks for one beyond it, the nearest end taken)."""
    t_stop, rate = model.changes[-1]
    floor = model.changes[-2][0] if len(model.changes) > 1 else anchor[0]
    lo, hi = max(t_stop - spread, floor + 1e-4, anchor[0]), min(t_stop + spread, frame[0])

    def turned(t: float) -> float:
        model.changes[-1] = (t, rate)
        return anchor[1] + model.at(frame[0])[0] - model.at(anchor[0])[0]

    if lo >= hi:
        model.changes[-1] = (t_stop, rate)
        return t_stop, False
    if turned(lo) >= frame[1] or turned(hi) <= frame[1]:
        end = lo if turned(lo) >= frame[1] else hi
        model.changes[-1] = (end, rate)
        return end, False
    for _ in range(24):                     # to a few microseconds
        mid = (lo + hi) / 2
        lo, hi = (lo, mid) if turned(mid) >= frame[1] else (mid, hi)
    model.changes[-1] = ((lo + hi) / 2, rate)
    return (lo + hi) / 2, True


def rest_angle(model: RampModel, anchor: tuple[float, float]) -> float:
    """The angle where the robot comes to rest, by ``model`` carried on from ``anchor``
    (time, angle turned); its commands end with a stop."""
    end = model.changes[-1][0] + 5.0
    return anchor[1] + model.at(end)[0] - model.at(anchor[0])[0]
