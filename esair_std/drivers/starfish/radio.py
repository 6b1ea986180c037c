"""The radio between STARFISH and the remote control center, as a function of where the
robot is: the link is up while the robot is within ``range_m`` of the access point and
no wall stands between them; it is cut otherwise. ``heal_m`` (hysteresis): once cut, the
link comes back only within ``range_m - heal_m``, so a robot on the edge does not make
it flap.

The model is pure: ``update(x, y)`` returns the state; the driver's ``radio`` sensor
reports it, the namespace tests turn it into a veth going down and up.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from .scene import Scene

if TYPE_CHECKING:  # pragma: no cover
    from ...transport.codec import JSONObject


class RadioModel:
    def __init__(self, room: Scene, range_m: float = 3.0, heal_m: float = 0.1):
        if range_m <= 0 or not 0 <= heal_m < range_m:
            raise ValueError(f"radio range {range_m} m / hysteresis {heal_m} m: need range > 0 "
                             "and 0 <= hysteresis < range")
        self.room, self.range_m, self.heal_m = room, float(range_m), float(heal_m)
        self.up = True
        self.cuts = 0

    def update(self, x: float, y: float) -> JSONObject:
        ap = self.room.access_point
        dist = math.hypot(x - ap[0], y - ap[1])
        los = not self.room.blocked((x, y), ap)
        reach = self.range_m - (self.heal_m if not self.up else 0.0)
        up = los and dist <= reach
        if self.up and not up:
            self.cuts += 1
        self.up = up
        return {"up": up, "distance": round(dist, 3), "los": los}
