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
from esair_min.core.image import crc16_ccitt
from esair_min.components.motion.layout import DIR_ENTRY_BYTES, HEADER_BYTES, MAGIC, VERSION
from esair_min.core.player import BalanceReaction, Player
from esair_min.core.protocol import Code
from esair_min.model.encoding import encode_pair, pair_fits
from esair_min.model.robot import Robot

#: Bytes per EEPROM read while checking the image at reset (docs/protocol.md, Reset).
CHECK_CHUNK = 32
#: The first magic byte of an image while it is being written (docs/protocol.md,
#: "Writing the motion image"): the header chunk is stored with it, commit writes 'E'.
OPEN_MAGIC = 0xFF
#: Actions refused while a motion plays (E07).
BUSY_ACTIONS = frozenset({"stand", "motor", "angles", "play", "image_write", "image_read",
                          "image_commit"})


class CentralCore:
    """The central board's decoder, command execution, frame player and reaction."""

    def __init__(self, robot: Robot, bus: Bus, send: Callable[[bytes], None],
                 robot_id: str | None = None, build_id: str | None = None):
        self.robot = robot
        # the v reply's id= (docs/protocol.md, "Robot id"): an emulator's boot; the
        # firmware has none
        self.robot_id = robot_id
        # the firmware's build id (codegen.build_id) in v and !READY; None: no build=
        self.build_id = build_id
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
        self._eeprom_size = eep.size_bytes if eep else 0
        self._page = eep.page_bytes if eep else 1
        self._lines = LineAssembler()
        self._feed = self._lines.feed
        self._speeds = list(self._default_speeds)
        self._targets = list(self._stand)
        self._player = Player(bus, self._eeprom or 0, self._eeprom_abytes,
                              self._actuator or 0, self._limits, self._targets)
        sensors = robot.sensors
        self._reactions = tuple(
            BalanceReaction(r.name,
                            [i for i, s in enumerate(sensors) if s.group == r.compare[0]],
                            [i for i, s in enumerate(sensors) if s.group == r.compare[1]],
                            r.threshold, r.samples, r.poll_ticks, numbers[r.motion])
            for r in robot.central.reactions)
        self._held: tuple[bytes, dict[int, int]] | None = None
        self._reactions_held = False   # h1: a reaction that fires moves nothing (RAM only)
        self._image_ok = False
        self._crc = 0            # the valid image's CRC (v, !READY)
        self._count = 0          # motions in its directory
        self._w_open = False     # an image write is open (its header chunk was written)
        self._w_len = 0          # that image's length
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
    def image_crc(self) -> int | None:
        """The CRC of the valid image, None while the image is not valid."""
        return self._crc if self._image_ok else None

    @property
    def writing(self) -> bool:
        """An image write is open (until a commit that checks)."""
        return self._w_open

    @property
    def last_sensors(self) -> tuple[int, ...] | None:
        return self._last_sensors

    @property
    def reactions_held(self) -> bool:
        """The reactions are held (``h1`` since the last ``h0`` or reset)."""
        return self._reactions_held

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
        self._reactions_held = False
        self._ticks = 0
        self._last_sensors = None
        self._w_open = False
        self._image_ok = self._check_image(MAGIC[0])
        self.send(P.ready_line(self._image_ok, self._crc, self.build_id))

    def _check_image(self, magic0: int) -> bool:
        """The image on the EEPROM (docs/protocol.md, Reset): its header (one read), the
        bytes it covers in reads of CHECK_CHUNK against its CRC, then each directory
        entry (one read each): its servo count is this robot's, its frames follow the
        previous motion's, the last ends the image. ``magic0``: the first magic byte
        expected ('E'; OPEN_MAGIC while a write is open)."""
        if self._eeprom is None:
            return True
        header = self._read_eeprom(0, HEADER_BYTES)
        if (header is None or header[0] != magic0 or header[1] != MAGIC[1]
                or header[2] != VERSION):
            return False
        count = header[3]
        length = header[4] | header[5] << 8
        expect = HEADER_BYTES + DIR_ENTRY_BYTES * count   # where the frames must start
        if length > self._eeprom_size or length < expect:
            return False
        crc = 0xFFFF
        for at in range(HEADER_BYTES, length, CHECK_CHUNK):
            chunk = self._read_eeprom(at, min(CHECK_CHUNK, length - at))
            if chunk is None:
                return False
            crc = crc16_ccitt(chunk, crc)
        if crc != header[6] | header[7] << 8:
            return False
        for i in range(count):
            entry = self._read_eeprom(HEADER_BYTES + DIR_ENTRY_BYTES * i, DIR_ENTRY_BYTES)
            if entry is None or entry[3] != self._n or entry[4] | entry[5] << 8 != expect:
                return False
            expect = (expect + entry[1] * 2 * self._n) & 0xFFFF
        if expect != length:
            return False
        self._crc = crc
        self._count = count
        return True

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
        if action in BUSY_ACTIONS and self._player.playing is not None:
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
                                               self._checksum, self.robot_id, self._crc,
                                               self.build_id)))
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
        if action == "hold":
            self._reactions_held = bool(args[0])
            self.send(P.OK_LINE)
            return None
        if action == "image_write":
            return self._image_write(args[0])
        if action == "image_read":
            return self._image_read(args[0])
        if action == "image_commit":
            return self._image_commit()
        if action == "i2c_scan":
            found = [a for a in range(P.SCAN_FIRST, P.SCAN_LAST + 1) if self.bus.write(a, b"")]
            self.send(("OK" + "".join(f" {a:02X}" for a in found)).encode() + P.EOL)
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
        if not self._image_ok:
            return Code.IMAGE_INVALID
        code = self._start(number)
        if code is not None:
            return code
        self.send(P.OK_LINE)
        return None

    def _start(self, number: int) -> Code | None:
        """Find motion ``number`` in the image's directory (one read per entry, in
        order) and start it; E08 if it has none, E10 if a read fails."""
        self._player.stop()
        for i in range(self._count):
            entry = self._read_eeprom(HEADER_BYTES + DIR_ENTRY_BYTES * i, DIR_ENTRY_BYTES)
            if entry is None:
                return Code.NO_ANSWER
            if entry[0] == number:
                ok = self._player.start(number, entry[1], entry[2], entry[4] | entry[5] << 8)
                return None if ok else Code.NO_ANSWER
        return Code.NO_MOTION

    # -- writing the image (docs/protocol.md, "Writing the motion image") ---------------
    def _image_write(self, raw: bytes) -> Code | None:
        """``raw``: address (2 bytes), data, checksum byte."""
        if sum(raw) & 0xFF:
            return Code.BAD_CHECKSUM
        at = raw[0] << 8 | raw[1]
        data = bytearray(raw[2:-1])
        k = len(data)
        if at == 0:             # the header: its length bounds the writes that follow
            length = data[4] | data[5] << 8 if k >= HEADER_BYTES else 0
            if k < HEADER_BYTES or length > self._eeprom_size:
                return Code.BAD_ARGUMENT
        elif not self._w_open or at < HEADER_BYTES or at + k > self._w_len:
            return Code.BAD_ARGUMENT
        if at % self._page + k > self._page:
            return Code.BAD_ARGUMENT
        if at == 0:
            self._w_open = True
            self._w_len = length
            self._image_ok = False
            data[0] = OPEN_MAGIC
        return self._eeprom_write(at, bytes(data))

    def _eeprom_write(self, at: int, data: bytes) -> Code | None:
        """One page write, then ACK polling until its write cycle ends; OK or E10."""
        assert self._eeprom is not None
        if not self.bus.write(self._eeprom, at.to_bytes(self._eeprom_abytes, "big") + data):
            return Code.NO_ANSWER
        for _ in range(P.POLL_MAX):
            if self.bus.write(self._eeprom, b""):
                self.send(P.OK_LINE)
                return None
        return Code.NO_ANSWER

    def _image_read(self, raw: bytes) -> Code | None:
        at, n = raw[0] << 8 | raw[1], raw[2]
        if not 1 <= n <= P.READ_MAX or at + n > self._eeprom_size:
            return Code.BAD_ARGUMENT
        data = self._read_eeprom(at, n)
        if data is None:
            return Code.NO_ANSWER
        self.send(b"OK " + (data + bytes((P.chunk_checksum(at, data),))).hex().upper().encode()
                  + P.EOL)
        return None

    def _image_commit(self) -> Code | None:
        """With a write open: check the image as written (first magic byte OPEN_MAGIC),
        then write its 'E'. Always: check the image as at reset; OK if it is valid."""
        if self._w_open:
            if not self._check_image(OPEN_MAGIC):
                return Code.IMAGE_INVALID
            assert self._eeprom is not None
            if not self.bus.write(self._eeprom, bytes(self._eeprom_abytes) + MAGIC[:1]):
                return Code.NO_ANSWER
            for _ in range(P.POLL_MAX):
                if self.bus.write(self._eeprom, b""):
                    break
            else:
                return Code.NO_ANSWER
            self._w_open = False
        self._image_ok = self._check_image(MAGIC[0])
        if not self._image_ok:
            return Code.IMAGE_INVALID
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
                if self._reactions_held:      # held: told, nothing stopped or started
                    self.send(P.held_reaction_line(r.name))
                    continue
                self._player.stop()
                self.send(P.reaction_line(r.name))
                code = self._start(r.motion)
                if code is not None:
                    self.send(P.NOTICE_LINE[code])
