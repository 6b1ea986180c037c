"""Behaviors bench/small_computer.py deploys (imported by the runtime or an agent)."""

from __future__ import annotations

import os
import time

from esair_std import Behavior


class Stepper(Behavior):
    """Sends options['n'] servo commands to papaman.servo.l_knee, one every
    options['every'] seconds (phase drifting against the robot's tick), and keeps
    time.monotonic() just before each send (one clock for every process); with
    options['go'], not before that file exists (a run() behavior is busy: no puts).
    bench/papaman_std.py deploys it too (papaman_std_comps imports it)."""

    def start(self):
        self.knee = self.attach_actuator("papaman.servo.l_knee")
        self.sent: list[float] = []
        self.errors = 0

    def run(self):
        while self.options.get("go") and not os.path.exists(self.options["go"]):
            if self.stopping:
                return
            time.sleep(0.25)        # the bench's own wait: kept out of the CPU figure
        n, every = int(self.options["n"]), float(self.options["every"])
        for i in range(n):
            if self.stopping:
                return
            t = time.monotonic()
            try:
                self.knee.send({"angle": 100 + (i % 2) * 10, "speed": 0}, timeout=2.0)
                self.sent.append(t)
            except Exception:  # noqa: BLE001 - counted
                self.errors += 1
            time.sleep(max(0.0, every - (time.monotonic() - t)))

    def provide(self, requester):
        return {"sent": self.sent, "errors": self.errors,
                "done": len(self.sent) + self.errors == int(self.options["n"])}


class SeqCounter(Behavior):
    """Reads options['sensor'] every step and counts its samples and the sequence
    numbers it never saw (samples lost between the sensor and this behavior)."""

    def start(self):
        self.h = self.attach_sensor(self.options["sensor"], keep=int(self.options.get("keep", 64)))
        self.samples = 0
        self.lost = 0
        self.last: int | None = None

    def step(self):
        for s in self.h.samples():
            self.samples += 1
            if self.last is not None and s.seq > self.last + 1:
                self.lost += s.seq - self.last - 1
            self.last = s.seq

    def provide(self, requester):
        # where the lost ones went: never reached the handle (a link down), or pushed out
        # of it before this read them (None: a checkout from before the count)
        return {"samples": self.samples, "lost": self.lost,
                "missed": getattr(self.h, "missed", None), "overwritten": self.h.overwritten}
