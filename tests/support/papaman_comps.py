"""Behaviors the PAPA-MAN end-to-end tests deploy beside the example's own."""

from __future__ import annotations

from esair_std import Behavior, CommandError, ResourceLost


class Mover(Behavior):
    """Sends options['moves'] ([servo, angle, speed] each) once, in order, to
    papaman.servo.<servo>; provide() tells what each send gave."""

    def start(self):
        self.results = []
        self.handles = {}

    def run(self):
        for servo, angle, speed in self.options["moves"]:
            name = f"papaman.servo.{servo}"
            if name not in self.handles:
                self.handles[name] = self.attach_actuator(name)
            try:
                self.results.append(["ok", self.handles[name].send(
                    {"angle": angle, "speed": speed}, timeout=2.0)])
            except (CommandError, ResourceLost) as exc:
                self.results.append([type(exc).__name__, str(exc)])

    def receive(self, sender, data):
        """{"servo": s, "angle": a}: one more move, its outcome kept."""
        name = f"papaman.servo.{data['servo']}"
        h = self.handles.get(name) or self.attach_actuator(name)
        self.handles[name] = h
        try:
            self.results.append(["ok", h.send({"angle": data["angle"]}, timeout=2.0)])
        except (CommandError, ResourceLost) as exc:
            self.results.append([type(exc).__name__, str(exc)])

    def provide(self, requester):
        return {"results": self.results,
                "states": {n: h.state for n, h in self.handles.items()}}


class Nudger(Behavior):
    """Sends papaman.servo.l_knee an angle every step (100 and 110 in turn) and keeps
    each outcome, ``[kind, text]`` (ok, CommandError, ResourceLost), the last 400;
    provide() gives them with the number sent so far."""

    period = 0.05

    def start(self):
        self.knee = self.attach_actuator("papaman.servo.l_knee")
        self.outcomes = []
        self.sent = 0
        self.told = []

    def step(self):
        self.sent += 1
        try:
            self.knee.send({"angle": 100 + 10 * (self.sent % 2)}, timeout=0.5)
            self.outcomes.append(["ok", ""])
        except (CommandError, ResourceLost) as exc:
            self.outcomes.append([type(exc).__name__, str(exc)])
        del self.outcomes[:-400]

    def robot_stopped(self, by, reason):
        self.told.append(["stopped", by, reason])

    def robot_released(self, by):
        self.told.append(["released", by])

    def provide(self, requester):
        return {"outcomes": self.outcomes, "sent": self.sent, "told": self.told}


class Stopper(Behavior):
    """STOPs the robot with the reason it is put (``self.stop_robot``); provide() gives
    what each try raised ("" when it went)."""

    def start(self):
        self.tries = []

    def receive(self, sender, data):
        try:
            self.stop_robot(str(data))
            self.tries.append("")
        except Exception as exc:  # noqa: BLE001 - kept for the test
            self.tries.append(f"{type(exc).__name__}: {exc}")

    def provide(self, requester):
        return self.tries
