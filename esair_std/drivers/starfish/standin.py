"""A STAND-IN for STARFISH's emulated world: the robot's pose integrated from the body
velocity it was last commanded, in the room, in real time.

This is NOT the robot of issue 22 (its boards, their firmware, the omni-wheel kinematics
on the MCU, the optical-flow sensors): that robot is being built beside this code and
will be reached through the MinLink design once it lands. Until then this small model
gives the STD side a pose to render microphones, camera and radio from, with the rules
the boards will enforce so that behaviors written against it stay right:

- a body velocity command ``(vx, vy)`` in mm/s in the robot's frame and ``w`` in
  mrad/s, refused outside the limits (``max_speed``, ``max_turn``);
- a command watchdog: no command for ``watchdog_s`` and the robot stops (issue 22's
  board watchdog), so nothing moves that nobody asked to move now;
- the robot is a disc of ``radius``: a move that would bring it closer than that to a
  wall is not made (it stops at the wall; ``collisions`` counts them);
- odometry here is the integrated pose itself (the emulated flow sensors' error comes
  with issue 22's world).

``advance(now)`` integrates lazily up to ``now`` in steps of at most 5 ms; the clock is
injectable (``clock``), so tests drive virtual time.
"""

from __future__ import annotations

import math
import threading
import time
from typing import Callable, Sequence

from .room import Room, wrap

STEP_S = 0.005


class CommandRefused(ValueError):
    """A wheel command outside the robot's limits (the message says which)."""


class StandInWorld:
    def __init__(self, room: Room, pose: Sequence[float] = (1.0, 1.0, 0.0), radius: float = 0.15,
                 max_speed: float = 400.0, max_turn: float = 3000.0, watchdog_s: float = 0.5,
                 clock: Callable[[], float] = time.monotonic):
        self.room = room
        self.x, self.y, self.th = (float(v) for v in pose)
        self.radius, self.max_speed, self.max_turn = float(radius), float(max_speed), float(max_turn)
        self.watchdog_s = float(watchdog_s)
        self.clock = clock
        self.vx = self.vy = self.w = 0.0            # m/s, m/s, rad/s in the robot's frame
        self.t = clock()
        self.last_command = -math.inf
        self.collisions = 0
        self.watchdog_stops = 0
        self.lock = threading.Lock()
        if room.clearance((self.x, self.y)) < self.radius:
            raise ValueError(f"start pose ({self.x}, {self.y}) is closer than {self.radius} m to a wall")

    def command(self, vx: float, vy: float, w: float) -> None:
        """Body velocity: vx, vy in mm/s (robot frame), w in mrad/s."""
        for name, v, lim in (("vx", vx, self.max_speed), ("vy", vy, self.max_speed),
                             ("w", w, self.max_turn)):
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise CommandRefused(f"{name} must be a number, not {v!r}")
            if abs(v) > lim:
                unit = "mrad/s" if name == "w" else "mm/s"
                raise CommandRefused(f"{name} {v} {unit} is outside the limit +-{lim:g} {unit}")
        if math.hypot(vx, vy) > self.max_speed:
            raise CommandRefused(f"speed {math.hypot(vx, vy):.0f} mm/s is over the limit "
                                 f"{self.max_speed:g} mm/s")
        with self.lock:
            self._advance(self.clock())
            self.vx, self.vy, self.w = vx / 1000.0, vy / 1000.0, w / 1000.0
            self.last_command = self.t

    def stop(self) -> None:
        self.command(0, 0, 0)

    def place(self, x: float, y: float, th: float) -> None:
        """Put the robot somewhere (the operator's hand in simulation); it stands still."""
        if self.room.clearance((x, y)) < self.radius:
            raise ValueError(f"pose ({x}, {y}) is closer than {self.radius} m to a wall")
        with self.lock:
            self._advance(self.clock())
            self.x, self.y, self.th = float(x), float(y), wrap(float(th))
            self.vx = self.vy = self.w = 0.0

    def pose(self) -> tuple[float, float, float]:
        with self.lock:
            self._advance(self.clock())
            return self.x, self.y, self.th

    def moving(self) -> bool:
        with self.lock:
            self._advance(self.clock())
            return bool(self.vx or self.vy or self.w)

    def _advance(self, now: float) -> None:
        while self.t < now:
            if not (self.vx or self.vy or self.w):
                break                                # standing still: nothing to integrate
            dt = min(STEP_S, now - self.t)
            if (self.vx or self.vy or self.w) and self.t >= self.last_command + self.watchdog_s:
                self.vx = self.vy = self.w = 0.0
                self.watchdog_stops += 1
            if self.vx or self.vy or self.w:
                c, s = math.cos(self.th), math.sin(self.th)
                nx = self.x + (c * self.vx - s * self.vy) * dt
                ny = self.y + (s * self.vx + c * self.vy) * dt
                if self.room.clearance((nx, ny)) >= self.radius and not self.room.blocked(
                        (self.x, self.y), (nx, ny)):
                    self.x, self.y = nx, ny
                elif self.vx or self.vy:
                    self.vx = self.vy = 0.0          # stopped at the wall
                    self.collisions += 1
                self.th = wrap(self.th + self.w * dt)
            self.t += dt
        self.t = max(self.t, now)
