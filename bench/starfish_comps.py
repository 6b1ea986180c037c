"""Components bench/starfish_std.py deploys beside the starfish example's."""

from __future__ import annotations

import collections
import math

from esair_std import Behavior


class Tracker(Behavior):
    """The radio's cuts and heals with their times, and when the robot, after a cut,
    first moves toward the access point (its distance falling between two odometry
    samples): ``[{"cut": t, "back": t, "heal": t, "cut_xy", "heal_xy"}, ...]``."""

    period = 0.02

    def start(self):
        self.radio = self.attach_sensor("starfish.radio", keep=64)
        self.odometry = self.attach_sensor("starfish.odometry", keep=64)
        self.ap = tuple(self.options.get("access_point", (1.0, 1.0)))
        self.trips = []
        self.up = True
        self.last = None            # (t, x, y) of the previous odometry sample
        self.poses = collections.deque(maxlen=100)

    def at(self, t):
        """(x, y) of the odometry sample nearest to time t."""
        if not self.poses:
            return None
        return list(min(self.poses, key=lambda p: abs(p[0] - t))[1:])

    def step(self):
        odometry = self.odometry.samples()
        for s in odometry:
            self.poses.append((s.t, s.value["x"], s.value["y"]))
        for s in self.radio.samples():
            up = s.value["up"]
            if up != self.up:
                if not up:
                    self.trips.append({"cut": s.t, "back": None, "heal": None, "cut_xy": self.at(s.t)})
                elif self.trips:
                    self.trips[-1].update(heal=s.t, heal_xy=self.at(s.t))
                self.up = up
        for s in odometry:
            x, y = s.value["x"], s.value["y"]
            if self.last is not None and self.trips and self.trips[-1]["back"] is None \
                    and self.trips[-1]["heal"] is None and s.t > self.trips[-1]["cut"]:
                d0 = math.hypot(self.last[1] - self.ap[0], self.last[2] - self.ap[1])
                d1 = math.hypot(x - self.ap[0], y - self.ap[1])
                if d1 < d0 - 1e-4:
                    self.trips[-1]["back"] = s.t
            self.last = (s.t, x, y)

    def provide(self, requester):
        return self.trips
