"""Command lines for one robot, built from its validated board model; replies parsed.

Pure functions over the robot's board (:mod:`.board`: plain data taken from the model
``esair_min`` loads and validates, or that model itself, converted): the
command table's prefixes, the servos' limits and default speeds, the motions' numbers,
the sensors' order. Everything that can be refused before sending is refused here with
a :class:`LinkError` naming the servo, the value and the board file.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from esair_min.errors import ProtocolError
from esair_min.core.protocol import MAX_SPEED, encode_pair, frame_line

from .board import Board, Servo, board_of
from .link_errors import LinkError

if TYPE_CHECKING:  # pragma: no cover - the model is loaded by whoever opens a link
    from esair_min.model.robot import Robot

    from ...transport.codec import JSONObject

VERSION_PREFIX = "esair-min/1"


class RobotCommands:
    """The lines ``robot``'s central board understands, and the checks made before sending."""

    def __init__(self, robot: Board | Robot):
        self.robot = robot = board_of(robot)
        self.checksum = robot.checksum
        self.servos: dict[str, Servo] = {s.name: s for s in robot.servos}
        self.sensor_names: tuple[str, ...] = tuple(s.name for s in robot.sensors)
        self.groups: dict[str, tuple[str, ...]] = {}
        for s in robot.sensors:
            self.groups.setdefault(s.group, ())
            self.groups[s.group] += (s.name,)
        self.motion_numbers: dict[str, int] = dict(robot.motions)
        self._prefix: dict[str, str] = {}
        for c in robot.commands:
            if c.action not in self._prefix and not (c.action == "play" and c.motion):
                self._prefix[c.action] = c.prefix
        self.actuator_file = robot.actuator_file

    # -- building lines -----------------------------------------------------------------
    def prefix(self, action: str) -> str:
        try:
            return self._prefix[action]
        except KeyError:
            raise LinkError(f"robot {self.robot.name} has no {action!r} command in its "
                            f"command table") from None

    def wire(self, line: str) -> bytes:
        """The bytes sent for ``line``: with the ``*HH`` suffix when the board requires it."""
        return frame_line(line, self.checksum)

    def servo(self, name: str) -> Servo:
        try:
            return self.servos[name]
        except KeyError:
            raise LinkError(f"robot {self.robot.name} has no servo {name!r} (servos: "
                            f"{', '.join(self.servos)})") from None

    def motor(self, name: str, angle: object, speed: object = None) -> str:
        """``oMSAAA`` for servo ``name``; the angle is checked against its limits first."""
        servo = self.servo(name)
        if speed is None:
            speed = servo.default_speed
        if not isinstance(angle, int) or isinstance(angle, bool):
            raise LinkError(f"servo {name}: angle {angle!r} is not a whole number of degrees")
        if not isinstance(speed, int) or isinstance(speed, bool) or not 0 <= speed <= MAX_SPEED:
            raise LinkError(f"servo {name}: speed {speed!r} is not a speed code 0..{MAX_SPEED}")
        if not servo.min_angle <= angle <= servo.max_angle:
            raise LinkError(f"servo {name}: angle {angle} is outside its limits "
                            f"{servo.min_angle}..{servo.max_angle} ({self.actuator_file}); "
                            f"not sent")
        try:
            encode_pair(angle, speed)
        except ProtocolError as exc:
            raise LinkError(f"servo {name}: {exc}; not sent") from None
        letter = chr(ord("a") + servo.index)
        speed_letter = chr(ord("a") + speed)
        return f"{self.prefix('motor')}{letter}{speed_letter}{angle:03d}"

    def play(self, motion: object) -> str:
        """``PLYnn`` for a motion given by number or by name."""
        if isinstance(motion, str) and not motion.isdigit():
            if motion not in self.motion_numbers:
                raise LinkError(f"robot {self.robot.name} has no motion {motion!r} (motions: "
                                f"{', '.join(self.motion_numbers)})")
            number = self.motion_numbers[motion]
        else:
            try:
                number = int(motion)  # type: ignore[call-overload]
            except (TypeError, ValueError):
                raise LinkError(f"motion {motion!r} is neither a motion name nor a "
                                f"number") from None
        if not 0 <= number <= 99:
            raise LinkError(f"motion number {number} is outside 0..99")
        return f"{self.prefix('play')}{number:02d}"

    # -- replies --------------------------------------------------------------------------
    def action_of(self, line: str) -> str | None:
        """The action of a line built here (longest matching prefix), for reply checks."""
        best = None
        for c in self.robot.commands:
            if (line.startswith(c.prefix) and len(line) == c.length(len(self.servos))
                    and (best is None or len(c.prefix) > len(best.prefix))):
                best = c
        return best.action if best else None

    def plausible(self, line: str, data: str) -> bool:
        """Could ``OK <data>`` be the reply to ``line``? (Replies carry no sequence number:
        on a noisy line a reply to a line the noise made up must not pass for ours.)"""
        action = self.action_of(line)
        if action == "sensors":
            return self.parse_sensors(data, strict=False) is not None
        if action == "version":
            return data.startswith(VERSION_PREFIX)
        return data == ""

    def parse_sensors(self, data: str, strict: bool = True) -> tuple[int, ...] | None:
        """The readings of an ``s`` reply, in register order."""
        parts = data.split(",")
        ok = len(parts) == len(self.sensor_names) and all(p.isdigit() for p in parts)
        if not ok:
            if strict:
                raise LinkError(f"sensor reply {data!r} does not hold "
                                f"{len(self.sensor_names)} readings")
            return None
        return tuple(int(p) for p in parts)

    def feet(self, data: str) -> JSONObject:
        """The ``s`` reply as a sample value: readings by name and each group's sum."""
        values = self.parse_sensors(data)
        assert values is not None
        by_name = dict(zip(self.sensor_names, values))
        return {"values": {**by_name},
                "groups": {g: sum(by_name[n] for n in names) for g, names in self.groups.items()}}

    def expected_version(self) -> dict[str, str]:
        """The fields a ``v`` reply of the board files' robot must have."""
        return {"servos": str(len(self.servos)), "sensors": str(len(self.sensor_names)),
                "checksum": "on" if self.checksum else "off"}

    def check_version(self, data: str) -> dict[str, str]:
        """The fields of a ``v`` reply; refuse a robot that is not the one of the board files."""
        fields = dict(f.split("=", 1) for f in data.split()[1:] if "=" in f)
        for key, value in self.expected_version().items():
            if fields.get(key) != value:
                raise LinkError(f"the robot answers {key}={fields.get(key, '?')} but the board "
                                f"files of {self.robot.name} say {key}={value} "
                                f"({self.robot.source})")
        return fields
