"""The platform-independent central-board core (docs/protocol.md), pure Python.

No I/O and no clock: the core sees the hardware through a :class:`Bus` (I2C master
transactions) and a ``send`` callable (whole UART lines); the caller feeds received
bytes with :meth:`CentralCore.rx_byte` while :meth:`CentralCore.ready` and calls
:meth:`CentralCore.tick` on every Timer2 tick. It is the reference the generated C
core is compared with, trace for trace.
"""

from __future__ import annotations

import struct
from typing import Callable

from esair_min.core import protocol as P
from esair_min.core.i2c_bus import Bus
from esair_min.core.decoder import CommandTable, LineAssembler, Row
from esair_min.core.image import build_image, crc16_ccitt
from esair_min.components.motion.layout import HEADER_BYTES
from esair_min.core.player import BalanceReaction, Player
from esair_min.core.protocol import Code
from esair_min.model.encoding import encode_pair, pair_fits
from esair_min.model.robot import Robot

#: Bytes per EEPROM read while checking the image at reset (docs/protocol.md, Reset).
CHECK_CHUNK = 32


class CentralCore:
    """The central board's decoder, command execution, frame player and reaction."""

    def __init__(self, robot: Robot, bus: Bus, send: Callable[[bytes], None],
                 robot_id: str | None = None):
        self.robot = robot
        # the v reply's id= (docs/protocol.md, "Robot id"): an emulator's boot; the
        # firmware has none
        self.robot_id = robot_id
        self.bus = bus
        self.send = send
        servos = robot.servos
        self._n = len(servos)
        self._limits = tuple((s.min_angle, s.max_angle) for s in servos)
        self._stand = tuple(s.stand_angle for s in servos)
        self._default_speeds = tuple(s.default_speed for s in servos)
        numbers = {m.name: m.number for m in robot.motions}
        uart = robot.central.uart
        self._checksum = bool(uart and uart.require_checksum)
        self._table = CommandTable(robot.commands, self._n, numbers, self._checksum)
        act, sen, eep = robot.peer("actuator"), robot.peer("sensor"), robot.eeprom
        self._actuator = act.address if act else None
        self._sensor = sen.address if sen else None
        self._sensor_regs = sen.registers if sen else 0
        self._n_sensors = len(robot.sensors)
        self._readings = struct.Struct(f"<{self._n_sensors}H")
        self._eeprom = eep.address if eep else None
        self._eeprom_abytes = eep.address_bytes if eep else 2
        self._image = build_image(robot) if eep else b""   # "compiled into the firmware"
        self._lines = LineAssembler()
        self._feed = self._lines.feed
        self._speeds = list(self._default_speeds)
        self._targets = list(self._stand)
        self._player = Player(bus, self._eeprom or 0, self._eeprom_abytes,
                              self._actuator or 0, self._limits, robot.layout.slots,
                              self._targets)
        sensors = robot.sensors
        self._reactions = tuple(
            BalanceReaction(r.name,
                            [i for i, s in enumerate(sensors) if s.group == r.compare[0]],
                            [i for i, s in enumerate(sensors) if s.group == r.compare[1]],
                            r.threshold, r.samples, r.poll_ticks, numbers[r.motion])
            for r in robot.central.reactions)
        self._held: tuple[bytes, dict[int, int]] | None = None
        self._image_ok = False
        self._ticks = 0
        self._last_sensors: tuple[int, ...] | None = None

    # -- read-only views ---------------------------------------------------------------
    @property
    def playing(self) -> int | None:
        return self._player.playing

    @property
    def speeds(self) -> tuple[int, ...]:
        return tuple(self._speeds)

    @property
    def targets(self) -> tuple[int, ...]:
        return tuple(self._targets)

    @property
    def image_ok(self) -> bool:
        return self._image_ok

    @property
    def last_sensors(self) -> tuple[int, ...] | None:
        return self._last_sensors

    @property
    def ticks(self) -> int:
        return self._ticks

    @property
    def line_length(self) -> int:
        """Bytes of the line being assembled (never above the 40-byte buffer)."""
        return self._lines.length

    # -- reset -------------------------------------------------------------------------
    def boot(self) -> None:
        """Reset: every state to its start value, check the image, send ``!READY``."""
        self._lines.reset()
        self._speeds[:] = self._default_speeds
        self._targets[:] = self._stand
        self._player.stop()
        for r in self._reactions:
            r.count = 0
            r.failing = False
        self._held = None
        self._ticks = 0
        self._last_sensors = None
        self._image_ok = self._check_image()
        self.send(P.ready_line(self._image_ok))

    def _check_image(self) -> bool:
        """Header (one read) against the compiled one, then its body in reads of
        CHECK_CHUNK bytes against the compiled CRC."""
        if self._eeprom is None:
            return True
        expected = self._image
        header = self._read_eeprom(0, HEADER_BYTES)
        if header is None or header != expected[:HEADER_BYTES]:
            return False
        crc = 0xFFFF
        for at in range(HEADER_BYTES, len(expected), CHECK_CHUNK):
            chunk = self._read_eeprom(at, min(CHECK_CHUNK, len(expected) - at))
            if chunk is None:
                return False
            crc = crc16_ccitt(chunk, crc)
        return crc == int.from_bytes(expected[6:8], "little")

    def _read_eeprom(self, at: int, n: int) -> bytes | None:
        assert self._eeprom is not None
        data = self.bus.write_read(self._eeprom, at.to_bytes(self._eeprom_abytes, "big"), n)
        return None if data is None or len(data) != n else bytes(data)

    # -- receiving ---------------------------------------------------------------------
    def ready(self) -> bool:
        """False while an actuator write is held for the tick (do not feed bytes)."""
        return self._held is None

    def rx_overrun(self) -> None:
        """The receive ring lost bytes right before the next byte to be fed (the port
        marks the loss at its place in the ring): the line being received is damaged
        from its start through the gap to the next line end, which answers it
        ``E12 input overrun`` once; it moves nothing. Lines that ended before the gap
        were complete and run as usual."""
        self._lines.note_overrun()

    def rx_byte(self, b: int) -> None:
        """One received byte. Fed while not :meth:`ready`, the byte counts as lost."""
        if self._held is not None:
            self._lines.note_overrun()
            return
        r = self._feed(b)
        if r is not None:
            self._line(r)

    def rx_run(self, data: bytes) -> None:
        """Bytes received back to back: exactly :meth:`rx_byte` of each in turn."""
        feed, lines = self._feed, self._lines
        for b in data:
            if self._held is not None:
                lines.note_overrun()
                continue
            r = feed(b)
            if r is not None:
                self._line(r)

    def _line(self, line: Code | bytes) -> None:
        if isinstance(line, Code):
            self.send(P.ERROR_LINE[line])
            return
        table = self._table
        body = table.strip_checksum(line)
        if isinstance(body, Code):
            self.send(P.ERROR_LINE[body])
            return
        row = table.match(body)
        if isinstance(row, Code):
            self.send(P.ERROR_LINE[row])
            return
        action = row.action
        if action in ("stand", "motor", "angles", "play") and self._player.playing is not None:
            self.send(P.ERROR_LINE[Code.BUSY])
            return
        args = table.parse(row, body)
        if args is None:
            self.send(P.ERROR_LINE[Code.BAD_ARGUMENT])
            return
        code = self._execute(row, args)
        if code is not None:
            self.send(P.ERROR_LINE[code])

    # -- execution ---------------------------------------------------------------------
    def _execute(self, row: Row, args: tuple) -> Code | None:
        """Run a decoded command; an error code, or None when replied/held."""
        action = row.action
        if action == "stand":
            return self._hold_all(self._stand)
        if action == "angles":
            return self._hold_all(tuple(t if a is None else a
                                        for a, t in zip(args, self._targets)))
        if action == "motor":
            m, speed, angle = args
            lo, hi = self._limits[m]
            if not lo <= angle <= hi:
                return Code.OUTSIDE_LIMITS
            if not pair_fits(angle, speed):
                return Code.OVERFLOW
            self._held = (bytes((2 * m, *encode_pair(angle, speed))), {m: angle})
            return None
        if action == "play":
            return self._play(args[0])
        if action == "speeds":
            self._speeds[:] = args
            self.send(P.OK_LINE)
            return None
        if action == "version":
            self.send(P.ok_line(P.version_data(self._n, self._n_sensors,
                                               len(self.robot.motions), self._image_ok,
                                               self._checksum, self.robot_id)))
            return None
        if action == "sensors":
            values = self._read_sensors()
            if values is None:
                return Code.NO_ANSWER
            self.send(P.ok_line(",".join(str(v) for v in values)))
            return None
        if action == "stop":
            self._player.stop()
            self.send(P.OK_LINE)
            return None
        raise AssertionError(f"unknown action {action}")  # the model allows no other

    def _hold_all(self, angles: tuple[int, ...]) -> Code | None:
        """Check every servo's new angle (E04, then E05) and hold the burst write."""
        for (lo, hi), angle in zip(self._limits, angles):
            if not lo <= angle <= hi:
                return Code.OUTSIDE_LIMITS
        data = bytearray(1 + 2 * self._n)   # register 0, then (low, high) per servo
        for i, (angle, speed) in enumerate(zip(angles, self._speeds)):
            if not pair_fits(angle, speed):
                return Code.OVERFLOW
            data[1 + 2 * i:3 + 2 * i] = bytes(encode_pair(angle, speed))
        self._held = (bytes(data), dict(enumerate(angles)))
        return None

    def _play(self, number: int) -> Code | None:
        if not self._player.has(number):
            return Code.NO_MOTION
        if not self._image_ok:
            return Code.IMAGE_INVALID
        if not self._player.start(number):
            return Code.NO_ANSWER
        self.send(P.OK_LINE)
        return None

    def _read_sensors(self) -> tuple[int, ...] | None:
        if self._sensor is None:
            return None
        regs = self.bus.write_read(self._sensor, b"\x00", self._sensor_regs)
        if regs is None or len(regs) != self._sensor_regs:
            return None
        values = self._readings.unpack_from(regs)   # (low, high) pair per sensor
        self._last_sensors = values
        return values

    # -- the tick ----------------------------------------------------------------------
    def tick(self) -> None:
        """One Timer2 tick: (1) held write and its reply, (2) player, (3) reaction."""
        self._ticks += 1
        held = self._held
        if held is not None:
            self._held = None
            data, angles = held
            if self._actuator is not None and self.bus.write(self._actuator, data):
                for i, a in angles.items():
                    self._targets[i] = a
                self.send(P.OK_LINE)
            else:
                self.send(P.ERROR_LINE[Code.NO_ANSWER])
        code = self._player.step()
        if code is not None:
            self.send(P.NOTICE_LINE[code])
        for r in self._reactions:
            if not r.due(self._ticks, self._player.playing):
                continue
            values = self._read_sensors()
            if values is None:
                if r.failed():
                    self.send(P.NOTICE_LINE[Code.NO_ANSWER])
                continue
            if r.sample(values) and self._image_ok:
                self._player.stop()
                self.send(P.reaction_line(r.name))
                if not self._player.start(r.motion):
                    self.send(P.NOTICE_LINE[Code.NO_ANSWER])
