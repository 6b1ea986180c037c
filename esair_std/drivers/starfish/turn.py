"""STARFISH's turn in place at its physical limits (docs/std-starfish.md, "the shot").

The board files set the limits: the central board's ``max_omega_mrad_s`` and each
wheel's ``limit_mm_s`` cap the turn rate, the drive board's ``ramp_mm_s2`` over the
wheels' ``mount_radius_mm`` the angular acceleration (the board ramps every wheel toward
its commanded speed by that much each control tick). A turn commanded at the top rate
and stopped at the right moment follows the time-optimal profile (trapezoid, or triangle
when too short to reach the top rate): the board's own ramp speeds it up and slows it
down. :class:`RampModel` replays the commands through that ramp, so the behavior can
predict where the robot will come to rest if it stops now. Pure computation.
"""

from __future__ import annotations

import math
from typing import Any


def turn_limits(robot: Any) -> tuple[float, float]:
    """(top turn rate rad/s, angular acceleration rad/s^2) of an omni base's robot model
    (esair_min.model): the smallest the central board and every wheel allow."""
    base = robot.central.base
    motors = _motors(robot)
    omega = min([base.max_omega_mrad_s / 1000.0] +
                [m.limit_mm_s / m.mount_radius_mm for m in motors])
    accel = min(m.ramp_mm_s2 / m.mount_radius_mm for m in motors)
    return omega, accel


def _motors(robot: Any) -> Any:
    drive = robot.board("drive")
    if drive is None or base_of(robot) is None:
        raise ValueError(f"robot {robot.name!r} has no omni base (a central board with "
                         f"'base:' and a drive board)")
    return drive.motors


def base_of(robot: Any) -> Any:
    return robot.central.base


def wheel_radius(robot: Any) -> float:
    """The wheels' largest distance from the centre (mm)."""
    return float(max(m.mount_radius_mm for m in _motors(robot)))


def flow_limit(robot: Any) -> tuple[float, float]:
    """(the flow sensors' top speed mm/s, their largest distance from the centre mm): a
    sensor moving faster loses counts, and the odometry its heading."""
    from esair_min.components.optical_flow.core import MAX_SPEED_IPS, MM_PER_INCH
    radius = max(math.hypot(f.mount_x_mm, f.mount_y_mm) for f in robot.central.flow_sensors)
    return MAX_SPEED_IPS * MM_PER_INCH, radius


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


def _ramp(angle: float, speed: float, target: float, accel: float, dt: float) -> tuple[float, float]:
    """Angle and rate after ``dt`` s of ramping from ``speed`` toward ``target``."""
    reach = abs(target - speed) / accel
    step = math.copysign(accel, target - speed)
    if dt <= reach:
        return angle + speed * dt + 0.5 * step * dt * dt, speed + step * dt
    return angle + speed * reach + 0.5 * step * reach * reach + target * (dt - reach), target


def stop_time(model: RampModel, angle_then: float, t_then: float, now: float, goal: float,
              latency: float, horizon: float) -> float | None:
    """The first time in [now, now + horizon] at which a stop sent (arriving ``latency``
    s later) brings the robot to rest at ``goal`` rad: ``angle_then`` was measured at
    ``t_then`` (odometry), the model carries it on; None if not within the horizon."""
    base = model.at(t_then)[0]
    accel = model.accel

    def reaches(t: float) -> bool:
        angle, rate = model.at(t + latency)
        return angle_then + angle - base + rate * rate / (2 * accel) >= goal

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
