"""The EEPROM motion image (docs/eeprom-format.md): build, parse, Intel HEX.

The layout (offsets and sizes) comes from :mod:`esair_min.components.motion.layout`; this module makes
and checks the bytes.
"""

from __future__ import annotations

import binascii
import io
import struct
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from esair_min.errors import ImageError
from esair_min.model.encoding import PAIR_HIGH_MAX, encode_pair, pair_fits
from esair_min.components.motion.layout import DIR_ENTRY_BYTES, HEADER_BYTES, MAGIC, VERSION

if TYPE_CHECKING:
    from esair_min.model.robot import Robot

BLANK = 0xFF


def crc16_ccitt(data: bytes | bytearray, crc: int = 0xFFFF) -> int:
    """CRC-16/CCITT-FALSE: poly 0x1021, init 0xFFFF, no reflection, no final XOR.

    ``crc16_ccitt(b"123456789") == 0x29B1``. Pass ``crc`` to continue a running CRC.
    The standard library's ``binascii.crc_hqx`` is this CRC (it was a hand-made table).
    """
    return binascii.crc_hqx(data, crc)


@dataclass(frozen=True)
class ImageHeader:
    magic: bytes
    version: int
    count: int
    length: int
    crc: int

    def pack(self) -> bytes:
        return self.magic + struct.pack("<BBHH", self.version, self.count, self.length, self.crc)


@dataclass(frozen=True)
class ParsedMotion:
    number: int
    delay_ticks: int
    offset: int
    frames: tuple[bytes, ...]   # raw frames, 2 bytes per servo

    def poses(self) -> tuple[tuple[tuple[int, int], ...], ...]:
        """Each frame as ``(angle, speed)`` per servo (thesis decoding)."""
        return tuple(tuple(((f[i + 1] % 10) * 100 + f[i], f[i + 1] // 10)
                           for i in range(0, len(f), 2)) for f in self.frames)


@dataclass(frozen=True)
class ParsedImage:
    header: ImageHeader
    frame_bytes: int
    motions: tuple[ParsedMotion, ...]

    def motion(self, number: int) -> ParsedMotion | None:
        return next((m for m in self.motions if m.number == number), None)

    @property
    def frame_count(self) -> int:
        return sum(len(m.frames) for m in self.motions)


def header_of(image: bytes) -> ImageHeader:
    """The header fields of an image (no check)."""
    if len(image) < HEADER_BYTES:
        raise ImageError(f"image is {len(image)} bytes, shorter than its "
                         f"{HEADER_BYTES}-byte header")
    version, count, length, crc = struct.unpack_from("<BBHH", image, 2)
    return ImageHeader(bytes(image[:2]), version, count, length, crc)


def build_image(robot: Robot) -> bytes:
    """The motion image of ``robot``'s central board (docs/eeprom-format.md)."""
    servos = robot.servos
    layout = robot.layout
    length = layout.total_bytes
    eeprom = robot.eeprom
    if eeprom is not None and length > eeprom.size_bytes:
        raise ImageError(f"the motion image needs {length} bytes but EEPROM "
                         f"'{eeprom.name}' has {eeprom.size_bytes}")
    if length > 0xFFFF:
        raise ImageError(f"the motion image needs {length} bytes, more than 65535")
    by_number = {m.number: m for m in robot.motions}
    directory = bytearray()
    frames = bytearray()
    for slot in layout.slots:
        m = by_number[slot.number]
        directory += struct.pack("<BBBBH", slot.number, slot.frames, slot.delay_ticks,
                                 len(servos), slot.offset)
        for f, frame in enumerate(m.frames):
            if len(frame.angles) != len(servos):
                raise ImageError(f"motion '{m.name}' frame {f}: {len(frame.angles)} angles "
                                 f"for {len(servos)} servos")
            for angle, speed, servo in zip(frame.angles, frame.speeds(), servos):
                if not servo.min_angle <= angle <= servo.max_angle:
                    raise ImageError(f"motion '{m.name}' frame {f}: angle {angle} for servo "
                                     f"'{servo.name}' is outside its limits "
                                     f"{servo.min_angle}..{servo.max_angle}")
                low, high = encode_pair(angle, speed)
                if not pair_fits(angle, speed):
                    raise ImageError(f"motion '{m.name}' frame {f}: speed {speed} with angle "
                                     f"{angle} encodes to high byte {high}, more than "
                                     f"{PAIR_HIGH_MAX}")
                frames += bytes((low, high))
    body = bytes(directory + frames)
    assert HEADER_BYTES + len(body) == length
    header = ImageHeader(MAGIC, VERSION, len(layout.slots), length, crc16_ccitt(body))
    return header.pack() + body


def parse_image(data: bytes, robot: Robot | None = None) -> ParsedImage:
    """Check and split an image (``data`` may carry trailing blank EEPROM bytes).

    With ``robot``, frames must also have its servo count and stay inside its limits.
    """
    h = header_of(data)
    if h.magic != MAGIC:
        raise ImageError(f"bad magic {h.magic!r} (expected {MAGIC!r})")
    if h.version != VERSION:
        raise ImageError(f"unsupported image version {h.version} (expected {VERSION})")
    dir_end = HEADER_BYTES + DIR_ENTRY_BYTES * h.count
    if h.length < dir_end or h.length > len(data):
        raise ImageError(f"image length {h.length} does not fit the {len(data)} bytes "
                         f"given and a {h.count}-motion directory")
    crc = crc16_ccitt(data[HEADER_BYTES:h.length])
    if crc != h.crc:
        raise ImageError(f"CRC mismatch: header says 0x{h.crc:04X}, bytes give 0x{crc:04X}")
    entries = [struct.unpack_from("<BBBBH", data, HEADER_BYTES + DIR_ENTRY_BYTES * i)
               for i in range(h.count)]
    last = -1
    servo_counts = {e[3] for e in entries}
    for number, count, delay, servos, _ in entries:
        if number <= last or number > 99:
            raise ImageError(f"directory: motion number {number} out of order or above 99")
        if count == 0 or delay == 0 or servos == 0 or len(servo_counts) > 1:
            raise ImageError(f"directory: motion {number} has frames {count}, "
                             f"delay {delay}, servos {servos}")
        if robot is not None and servos != len(robot.servos):
            raise ImageError(f"directory: motion {number} has {servos} servos, the robot "
                             f"{len(robot.servos)}")
        last = number
    total_frames = sum(e[1] for e in entries)
    frames_bytes = h.length - dir_end
    if robot is not None:
        frame_bytes = 2 * len(robot.servos)
    elif servo_counts:
        frame_bytes = 2 * next(iter(servo_counts))
    else:
        frame_bytes = 0
    if (frame_bytes == 0 or frame_bytes % 2 or frame_bytes * total_frames != frames_bytes) and (
            h.count or frames_bytes):
        raise ImageError(f"{frames_bytes} frame bytes do not hold {total_frames} frames")
    motions = []
    offset = dir_end
    for number, count, delay, _, off in entries:
        if off != offset:
            raise ImageError(f"directory: motion {number} at offset {off}, expected {offset}")
        frames = tuple(bytes(data[off + k * frame_bytes: off + (k + 1) * frame_bytes])
                       for k in range(count))
        for k, f in enumerate(frames):
            _check_frame(number, k, f, robot)
        motions.append(ParsedMotion(number, delay, off, frames))
        offset += count * frame_bytes
    return ParsedImage(h, frame_bytes, tuple(motions))


def _check_frame(number: int, k: int, frame: bytes, robot: Robot | None) -> None:
    servos = robot.servos if robot is not None else ()
    for i in range(0, len(frame), 2):
        low, high = frame[i], frame[i + 1]
        if low >= 100:
            raise ImageError(f"motion {number} frame {k}: servo {i // 2} low byte {low} "
                             f"is not below 100")
        if servos:
            s = servos[i // 2]
            angle = (high % 10) * 100 + low
            if not s.min_angle <= angle <= s.max_angle:
                raise ImageError(f"motion {number} frame {k}: angle {angle} for servo "
                                 f"'{s.name}' is outside its limits "
                                 f"{s.min_angle}..{s.max_angle}")


# -- Intel HEX ------------------------------------------------------------------------

def write_hex(data: bytes, path: Path | str) -> None:
    """Write ``data`` (from address 0) as an Intel HEX file."""
    from intelhex import IntelHex

    ih = IntelHex()
    ih.frombytes(bytes(data), offset=0)
    try:
        ih.write_hex_file(str(path))
    except OSError as exc:
        raise ImageError(f"cannot write {path}: {exc.strerror}") from None


def read_hex(path: Path | str, size: int) -> bytes:
    """The ``size`` bytes of EEPROM an Intel HEX file describes (blank bytes 0xFF)."""
    from intelhex import HexReaderError, IntelHex

    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise ImageError(f"cannot read {path}: {exc.strerror}") from None
    ih = IntelHex()
    try:     # any byte is one character (latin-1); lines end at CR, LF or CRLF
        ih.loadhex(io.StringIO(data.decode("latin-1"), newline=None))
    except HexReaderError as exc:
        raise ImageError(f"{path}: not a valid Intel HEX file ({exc})") from None
    if len(ih) and ih.maxaddr() >= size:
        raise ImageError(f"{path}: data at address 0x{ih.maxaddr():X}, beyond the "
                         f"{size}-byte EEPROM")
    ih.padding = BLANK
    return bytes(ih.tobinarray(start=0, size=size))


def image_summary(robot: Robot, image: bytes) -> str:
    """One line: motions, frames, bytes used of the EEPROM, CRC."""
    h = header_of(image)
    frames = sum(s.frames for s in robot.layout.slots)
    size = robot.eeprom.size_bytes if robot.eeprom is not None else len(image)
    return (f"{robot.name}: {h.count} motions, {frames} frames, {h.length} of {size} "
            f"bytes used, CRC 0x{h.crc:04X}")
