"""Behaviors and the reaction of the example robot ``lab`` (lab.yaml)."""

from __future__ import annotations

from esair_std import Behavior, Reaction


class Follow(Behavior):
    """The arm follows the wave: angle 90 +- 60; every 10th step a note to the logger."""

    period = 0.02

    def start(self):
        self.wave = self.attach_sensor("wave")
        self.arm = self.attach_actuator("arm")
        self.steps = 0

    def step(self):
        self.steps += 1
        s = self.wave.latest()
        if s is None:
            return
        angle = round(90 + 60 * s.value)
        self.arm.send({"angle": angle})
        if self.steps % 10 == 0:
            self.put("logger", {"seq": s.seq, "angle": angle}, timeout=1.0)

    def provide(self, requester):
        return {"steps": self.steps}


class Logger(Behavior):
    """Keeps what others put to it; get() gives the count and the last one."""

    def start(self):
        self.count = 0
        self.last = None

    def receive(self, sender, data):
        self.count += 1
        self.last = {"from": sender, "data": data}

    def provide(self, requester):
        return {"received": self.count, "last": self.last}


class Tuner(Behavior):
    """Every second: the arm's speed between 3 and 7, and the guard off/on in turn."""

    period = 1.0

    def start(self):
        self.register("arm", "configure")
        self.n = 0

    def step(self):
        self.n += 1
        self.configure("arm", "speed", 3 + (self.n % 5))
        if self.n % 2:
            self.disable_reaction("guard")
        else:
            self.enable_reaction("guard")


class Keeper(Behavior):
    """Keeps the bench cool: the fan goes on above 21.0 degrees, off below 20.5."""

    period = 0.2

    def start(self):
        self.temp = self.attach_sensor("bench.temp")
        self.fan = self.attach_actuator("bench.fan")

    def step(self):
        s = self.temp.latest()
        if s is not None:
            self.fan.send("on" if s.value > 21.0 else "off" if s.value < 20.5 else
                          ("on" if s.value > 20.75 else "off"))


class Guard(Reaction):
    """Every 50th tick: the arm home (90), directly — no registration, no AC."""

    period = 0.05

    def start(self):
        self.ticks = self.resource("ticks")
        self.arm = self.resource("arm")

    def step(self):
        for s in self.ticks.samples():
            if s.value % 50 == 0:
                self.arm.send({"angle": 90})
