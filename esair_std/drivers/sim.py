"""Simulated drivers for examples and tests: a sine sensor, a counter sensor (its value
is its own sequence number, so losses show), a recording actuator, and a Driver giving
both kinds (a bench with a temperature sensor and a fan)."""

from __future__ import annotations

import math
import time

from ..errors import CommandError
from ..resource import Actuator, Driver, Sensor
from ..transport.codec import JSON, JSONObject


class Sine(Sensor):
    """``amplitude * sin(2 pi freq_hz t)``, polled at ``rate_hz`` (options)."""
    settings = ("amplitude", "freq_hz", "rate_hz")

    def open(self) -> None:
        self.rate_hz = float(self.options.get("rate_hz", 50))
        self.amplitude = float(self.options.get("amplitude", 1.0))
        self.freq_hz = float(self.options.get("freq_hz", 0.5))
        self.t0 = time.monotonic()

    def read(self) -> float:
        return round(self.amplitude * math.sin(2 * math.pi * self.freq_hz
                                               * (time.monotonic() - self.t0)), 6)

    def configure(self, key: str, value: JSON) -> object:
        if key in ("amplitude", "freq_hz"):
            number = float(value)   # type: ignore[arg-type]  # no number: TypeError, the caller's
            setattr(self, key, number)
            return number
        return super().configure(key, value)


class Counter(Sensor):
    """Reports 1, 2, 3, ... at ``rate_hz``: a receiver sees every gap."""

    def open(self) -> None:
        self.rate_hz = float(self.options.get("rate_hz", 10))
        self.n = 0

    def read(self) -> int:
        self.n += 1
        return self.n


class Recorder(Actuator):
    """Keeps the last ``keep`` commands; ``speed`` is configurable. A command
    ``{"angle": a}`` needs 0 <= a <= 180."""
    settings = ("speed",)

    def open(self) -> None:
        self.keep = int(self.options.get("keep", 100))
        self.commands: list[JSON] = []
        self.count = 0
        self.speed = int(self.options.get("speed", 5))

    def write(self, command: JSON) -> JSONObject:
        if isinstance(command, dict) and "angle" in command:
            a = command["angle"]
            if not isinstance(a, (int, float)) or not 0 <= a <= 180:
                raise CommandError(self.name, f"angle {a!r} out of range 0-180")
        self.count += 1
        self.commands = (self.commands + [command])[-self.keep:]
        return {"count": self.count, "speed": self.speed}

    def configure(self, key: str, value: JSON) -> object:
        if key == "speed":
            if not isinstance(value, int) or not 1 <= value <= 9:
                raise CommandError(self.name, f"speed {value!r} out of range 1-9")
            self.speed = value
            return value
        return super().configure(key, value)


class _Temp(Sensor):
    rate_hz = 5.0

    def read(self) -> float:
        bench: Bench = self._esair.host.driver
        return 20.0 + bench.fan_off_s() * 0.1


class _Fan(Actuator):
    def write(self, command: JSON) -> JSON:
        if command not in ("on", "off"):
            raise CommandError(self.name, f"expected 'on' or 'off', not {command!r}")
        self._esair.host.driver.set_fan(command == "on")
        return command


class Bench(Driver):
    """One simulated link with two resources: ``<entry>.temp`` (rises while the fan is
    off) and ``<entry>.fan`` (on/off)."""

    def open(self) -> None:
        self.fan_on = False
        self.since = time.monotonic()

    def fan_off_s(self) -> float:
        return 0.0 if self.fan_on else round(time.monotonic() - self.since, 1)

    def set_fan(self, on: bool) -> None:
        if on != self.fan_on:
            self.fan_on, self.since = on, time.monotonic()

    def resources(self) -> dict[str, Sensor | Actuator]:
        return {"temp": _Temp(), "fan": _Fan()}
