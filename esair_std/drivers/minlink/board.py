"""What the MinLink driver needs of a robot's board files, as plain data.

``esair_min`` loads and validates the board files (pydantic models, errors at
file:line); :func:`board_of` takes from that model only what the link uses — the
command table's prefixes and lengths, the servos' limits and default speeds, the
sensors' order and maxima, the motions' numbers, the line's baud, tick and I2C read —
so that a runtime given this data (``esair std run``, docs/std.md "Lean robot side")
never imports the model. Plain classes, not dataclasses (``dataclasses`` imports
``inspect`` and ``ast``).
"""

from __future__ import annotations

from typing import Any, Mapping

from ...transport.codec import JSONObject


class _Plain:
    """Attributes set once from keyword values; compared by value; shown by repr."""

    __slots__: tuple[str, ...] = ()

    def __init__(self, **values: Any):
        for key in self.__slots__:
            object.__setattr__(self, key, values[key])

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError(f"cannot assign to field {name!r} of {type(self).__name__}")

    def __eq__(self, other: object) -> bool:
        if type(other) is not type(self):
            return NotImplemented
        return all(getattr(self, k) == getattr(other, k) for k in self.__slots__)

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return (f"{type(self).__name__}("
                + ", ".join(f"{k}={getattr(self, k)!r}" for k in self.__slots__) + ")")

    def to_json(self) -> JSONObject:
        return {k: getattr(self, k) for k in self.__slots__}


class Servo(_Plain):
    __slots__ = ("name", "index", "min_angle", "max_angle", "default_speed")
    name: str
    index: int
    min_angle: int
    max_angle: int
    default_speed: int


class SensorInput(_Plain):
    __slots__ = ("name", "group", "max")
    name: str
    group: str
    max: int


class Command(_Plain):
    """One row of the command table, with its line length on this robot computed."""

    __slots__ = ("action", "prefix", "motion", "line_length")
    action: str
    prefix: str
    motion: str | None
    line_length: int           # characters of a matching line (checksum suffix excluded)

    def length(self, servos: int) -> int:     # as esair_min's Command: its robot's own
        return self.line_length


class Board:
    """One robot's link-relevant facts (see the module docstring)."""

    __slots__ = ("name", "source", "actuator_file", "checksum", "servos", "sensors",
                 "motions", "commands", "baud", "tick_s", "i2c_hz", "sensor_registers")
    name: str
    source: str
    actuator_file: str
    checksum: bool
    servos: tuple[Servo, ...]
    sensors: tuple[SensorInput, ...]
    motions: dict[str, int]
    commands: tuple[Command, ...]
    baud: int
    tick_s: float
    i2c_hz: int | None             # the central board's I2C clock (None: no I2C)
    sensor_registers: int          # registers of the sensor board read for ``s`` (0: none)

    def __init__(self, **values: Any):
        for key in self.__slots__:
            setattr(self, key, values[key])

    def __eq__(self, other: object) -> bool:
        if type(other) is not Board:
            return NotImplemented
        return self.to_json() == other.to_json()

    __hash__ = None  # type: ignore[assignment]

    def to_json(self) -> JSONObject:
        return dict(name=self.name, source=self.source, actuator_file=self.actuator_file,
                    checksum=self.checksum, servos=[s.to_json() for s in self.servos],
                    sensors=[s.to_json() for s in self.sensors], motions=dict(self.motions),
                    commands=[c.to_json() for c in self.commands], baud=self.baud,
                    tick_s=self.tick_s, i2c_hz=self.i2c_hz,
                    sensor_registers=self.sensor_registers)

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "Board":
        return cls(**{**d, "servos": tuple(Servo(**s) for s in d["servos"]),
                      "sensors": tuple(SensorInput(**s) for s in d["sensors"]),
                      "commands": tuple(Command(**c) for c in d["commands"]),
                      "motions": dict(d["motions"])})


def board_of(robot: Any) -> Board:
    """The plain board of esair_min's validated ``Robot`` model (already plain: itself)."""
    if isinstance(robot, Board):
        return robot
    central = robot.central
    uart, timer2 = central.uart, central.timer2
    assert uart is not None and timer2 is not None, "validated central boards have both"
    n = len(robot.servos)
    peer = robot.peer("sensor")
    return Board(
        name=robot.name, source=str(robot.source),
        actuator_file=robot.file_of(robot.actuator) if robot.actuator else "?",
        checksum=bool(uart.require_checksum),
        servos=tuple(Servo(name=s.name, index=s.index, min_angle=s.min_angle,
                           max_angle=s.max_angle, default_speed=s.default_speed)
                     for s in robot.servos),
        sensors=tuple(SensorInput(name=s.name, group=s.group, max=s.max)
                      for s in robot.sensors),
        motions={m.name: m.number for m in robot.motions},
        commands=tuple(Command(action=c.action, prefix=c.prefix, motion=c.motion,
                               line_length=c.length(n)) for c in robot.commands),
        baud=int(uart.baud), tick_s=float(timer2.period_s),
        i2c_hz=int(central.i2c.speed_hz) if central.i2c else None,
        sensor_registers=int(peer.registers) if peer is not None else 0)
