"""The robot body in the room: pose, integration of the body velocity, lag, slip and
wall collisions."""

from __future__ import annotations

import math
import random
from dataclasses import dataclass, field

from esair_min.world.room import Room

#: Bisection steps that find where along a step the body first touches a wall.
_CONTACT_STEPS = 16


@dataclass(frozen=True)
class Pose:
    """Where the robot is: x, y in mm, theta in rad (counter-clockwise from +x)."""

    x: float
    y: float
    theta: float

    def to_world(self, px: float, py: float) -> tuple[float, float]:
        """A point of the robot's frame (mm) in room coordinates."""
        c, s = math.cos(self.theta), math.sin(self.theta)
        return self.x + c * px - s * py, self.y + s * px + c * py


#: The velocity of a robot at rest (vx, vy, omega).
REST = (0.0, 0.0, 0.0)


def new_pose(x: float, y: float, theta: float) -> Pose:
    """``Pose(x, y, theta)`` without the frozen dataclass's ``__init__`` (a step's
    allocation: the same fields, the same object)."""
    p = _new(Pose)
    d = p.__dict__
    d["x"] = x
    d["y"] = y
    d["theta"] = theta
    return p


_new = object.__new__


@dataclass(frozen=True)
class WorldOptions:
    """How the body follows its commanded velocity.

    ``lag_s``: first-order time constant of the motors (0: at once); ``slip``: the
    fraction of the motion the wheels lose on the floor (0..1); ``slip_noise``: the
    standard deviation of that fraction from step to step; ``seed`` makes the noise
    repeatable."""

    radius_mm: float = 150.0
    lag_s: float = 0.0
    slip: float = 0.0
    slip_noise: float = 0.0
    seed: int = 0


@dataclass(frozen=True)
class Step:
    """What one :meth:`World.step` did: the velocity the body actually had in its own
    frame (mm/s, mm/s, rad/s), the time, and whether a wall stopped it."""

    vx: float
    vy: float
    omega: float
    dt_s: float
    collided: bool


@dataclass
class World:
    """A room and one robot body moving in it (virtual time only)."""

    room: Room = field(default_factory=Room.default)
    pose: Pose = Pose(2500.0, 2500.0, 0.0)
    options: WorldOptions = WorldOptions()
    t_s: float = 0.0
    collisions: int = 0       # contacts with a wall so far

    def __post_init__(self) -> None:
        self._v = (0.0, 0.0, 0.0)
        self._rng = random.Random(self.options.seed)
        self._touching = False
        self._checked = (self.pose.x, self.pose.y)
        self._margin = -1.0                  # no clearance measured yet

    @property
    def velocity(self) -> tuple[float, float, float]:
        """The body's actual velocity in its own frame after the last step."""
        return self._v

    def _follow(self, want: tuple[float, float, float], dt_s: float) -> tuple[float, float, float]:
        lag = self.options.lag_s
        if lag <= 0:
            return want
        k = 1.0 - math.exp(-dt_s / lag)
        return tuple(v + (w - v) * k for v, w in zip(self._v, want, strict=True))  # type: ignore[return-value]

    def _moved(self, pose: Pose, v: tuple[float, float, float], dt_s: float) -> Pose:
        vx, vy, omega = v
        mid = pose.theta + omega * dt_s / 2
        c, s = math.cos(mid), math.sin(mid)
        return Pose(pose.x + (c * vx - s * vy) * dt_s, pose.y + (s * vx + c * vy) * dt_s,
                    pose.theta + omega * dt_s)

    def _clear(self, pose: Pose) -> bool:
        # The body moved at most hypot(dx, dy) since the last clearance measured: while
        # that stays below the margin it had, no wall can be nearer than its radius.
        moved = math.hypot(pose.x - self._checked[0], pose.y - self._checked[1])
        if moved < self._margin:
            return True
        clearance = self.room.clearance(pose.x, pose.y)
        ok = clearance >= self.options.radius_mm
        if ok:
            self._checked = (pose.x, pose.y)
            self._margin = clearance - self.options.radius_mm
        return ok

    def advance(self, dt_s: float, vx: float, vy: float,
                omega: float) -> tuple[float, float, float, bool]:
        """:meth:`step`, returning the :class:`Step`'s ``(vx, vy, omega, collided)``
        without making one: a body without lag or slip that stays clear of the walls
        is moved here (the same floats as :meth:`step`), anything else by :meth:`step`."""
        opts = self.options
        if dt_s > 0 and not (opts.lag_s > 0 or opts.slip or opts.slip_noise):
            if vx == 0 and vy == 0 and omega == 0:            # at rest: only time passes
                self._v = REST
                self.t_s += dt_s
                return 0.0, 0.0, 0.0, False
            pose = self.pose
            th = pose.theta
            mid = th + omega * dt_s / 2                       # _moved, inlined
            c, s = math.cos(mid), math.sin(mid)
            x = pose.x + (c * vx - s * vy) * dt_s
            y = pose.y + (s * vx + c * vy) * dt_s
            cx, cy = self._checked
            if math.hypot(x - cx, y - cy) < self._margin:     # _clear(new), at once
                self._touching = False
                self.pose = new_pose(x, y, th + omega * dt_s)
                self._v = (vx, vy, omega)
                self.t_s += dt_s
                return vx, vy, omega, False
        st = self.step(dt_s, vx, vy, omega)
        return st.vx, st.vy, st.omega, st.collided

    def step(self, dt_s: float, vx: float, vy: float, omega: float) -> Step:
        """Advance ``dt_s`` seconds with the commanded body velocity (robot frame)."""
        if not dt_s > 0:
            raise ValueError(f"a step needs a time above 0 s, not {dt_s}")
        opts = self.options
        v = self._follow((vx, vy, omega), dt_s) if opts.lag_s > 0 else (vx, vy, omega)
        if v[0] == 0 and v[1] == 0 and v[2] == 0:          # at rest: only time passes
            self._v = (0.0, 0.0, 0.0)
            self.t_s += dt_s
            return Step(0.0, 0.0, 0.0, dt_s, False)
        if opts.slip or opts.slip_noise:
            keep = 1.0 - opts.slip - self._rng.gauss(0.0, opts.slip_noise)
            keep = max(0.0, min(1.0, keep))
            v = (v[0] * keep, v[1] * keep, v[2] * keep)
        new = self._moved(self.pose, v, dt_s)
        cx, cy = self._checked
        if math.hypot(new.x - cx, new.y - cy) < self._margin:     # _clear(new), at once
            self._touching = False
            self.pose = new
            self._v = v
            self.t_s += dt_s
            return Step(v[0], v[1], v[2], dt_s, False)
        collided = False
        if not self._clear(new) and self._clear(self.pose):
            lo, hi = 0.0, 1.0
            for _ in range(_CONTACT_STEPS):
                mid = (lo + hi) / 2
                if self._clear(self._moved(self.pose, v, dt_s * mid)):
                    lo = mid
                else:
                    hi = mid
            new = self._moved(self.pose, v, dt_s * lo)
            v = (v[0] * lo, v[1] * lo, v[2] * lo)
            collided = True
        elif not self._clear(new):
            new, v, collided = self.pose, (0.0, 0.0, 0.0), True
        if collided and not self._touching:
            self.collisions += 1          # one per contact, not per step spent at the wall
        self._touching = collided
        self.pose = new
        self._v = (0.0, 0.0, 0.0) if collided else v
        self.t_s += dt_s
        return Step(v[0], v[1], v[2], dt_s, collided)
