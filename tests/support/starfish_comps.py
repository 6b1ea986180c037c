"""Components the STARFISH tests deploy beside the example's (tests/std/test_starfish_std.py)."""

from __future__ import annotations

import math
import time

from esair_std import Behavior
from esair_std.drivers.starfish import Starfish


class RadioWatcher(Behavior):
    """Records the radio link's cuts and heals with the robot's distance to the access
    point then, and the nearest it came while the link was cut."""

    period = 0.05

    def start(self):
        self.radio = self.attach_sensor("starfish.radio", keep=64)
        self.ap = tuple(self.options.get("access_point", (1.0, 1.0)))
        self.events = []
        self.up = True
        self.nearest_while_down = None

    def step(self):
        for s in self.radio.samples():
            up, dist = s.value["up"], s.value["distance"]
            if up != self.up:
                self.events.append(["up" if up else "down", dist])
                self.up = up
                self.nearest_while_down = None if up else dist
            elif not up:
                self.nearest_while_down = min(self.nearest_while_down, dist)

    def provide(self, requester):
        return {"events": self.events, "up": self.up, "nearest_while_down": self.nearest_while_down,
                "gaps": 0 if not self.radio.received else self.radio.overwritten}


def true_bearing(pose, x, y):
    return math.atan2(y - pose[1], x - pose[0]) - pose[2]


def example_scene(source=(1.0, 3.2), on=False, access_point=(1.0, 1.0), inner_wall=True):
    """The example's room (esair_std/examples/starfish/room.yaml: 6 m x 4 m, the inner
    wall x = 3 m up to y = 2.5 m, three poles) as the sensors see it, with the sound
    source at ``source`` (metres) sounding or not."""
    from esair_min.world import Landmark, Room, Segment
    from esair_std.drivers.starfish.scene import from_world

    walls = Room.box(6000, 4000).walls + ((Segment(3000, 0, 3000, 2500),) if inner_wall else ())
    marks = (Landmark("bell", source[0] * 1000, source[1] * 1000, "sound"),
             Landmark("ap", access_point[0] * 1000, access_point[1] * 1000, "access_point"),
             Landmark("green", 400, 3600, "pole"), Landmark("yellow", 5600, 400, "pole"),
             Landmark("blue", 5600, 3600, "pole"))
    scene = from_world(Room(walls, marks))
    scene.source.on = on
    return scene


class SlowWheelsOnce(Starfish):
    """STARFISH (the real driver, its emulated boards) whose wheels answer ONE turn
    command late: the first ``{"w": ...}`` (turn_and_shoot's turns) is written ``slow_s``
    seconds late (past its sender's 0.5 s timeout), every other one at once."""

    def _open(self, opts: dict) -> None:
        self.slow_s = float(opts.pop("slow_s", 1.0))    # the driver checks the rest by name
        super()._open(opts)
        self.slowed = 0
        wheels = self.wheels
        write = wheels.write

        def slow_once(command):
            if isinstance(command, dict) and set(command) == {"w"} and not self.slowed:
                self.slowed += 1
                time.sleep(self.slow_s)      # the one late reply under test
            return write(command)
        wheels.write = slow_once


class OdometryTrace(Behavior):
    """Every odometry sample as [n (the central board's ticks), th, moving, t]: the
    robot's own record of a turn."""

    period = 0.05

    def start(self):
        self.odometry = self.attach_sensor("starfish.odometry", keep=64)
        self.trace = []

    def step(self):
        for s in self.odometry.samples():
            self.trace.append([s.value["n"], s.value["th"], s.value["moving"], s.t])

    def provide(self, requester):
        return {"trace": self.trace[-600:], "gaps": self.odometry.overwritten}
