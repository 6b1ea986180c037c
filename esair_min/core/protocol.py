"""The PC command protocol as pure functions (docs/protocol.md).

One place for the reply codes and their exact texts, the checksum, the servo pair
encoding of the thesis, helpers that build command lines (for clients and tests) and
a parser of reply lines. No I/O, no state.
"""

from __future__ import annotations

from enum import IntEnum
from typing import Iterable, NamedTuple, Sequence

from esair_min.errors import ProtocolError
from esair_min.model import encoding
from esair_min.model.encoding import CHECKSUM_CHARS, MAX_LINE  # noqa: F401  (the protocol's)

PROTOCOL_NAME = "esair-min/1"
EOL = b"\r\n"
MAX_SPEED = 25
ANGLE_STEP = 3         # the `c` command: char '0'..'l' is 3*(char-0x30) degrees
ANGLE_CODE_FIRST = 0x30
ANGLE_CODE_LAST = 0x6C
KEEP_CODE = "."
#: The central board's UART rings (every port and the emulator): bytes received and
#: not yet decoded, and bytes of replies not yet sent. The transmit ring holds the
#: longest reply with one slot always free: 80 on a STARFISH central board (its ``v``
#: and ``O`` replies); on a board with a command table (PAPA-MAN) 104, for its ``v`` with
#: the image's CRC and the build id (92 bytes) and a short reply still leaving before
#: it (as 80 had for its 68-byte ``v`` before them).
RX_RING = 64
TX_RING = 80
TX_RING_TABLE = 104
#: Data bytes a read of the image (``image_read``) returns at most: it is read into the
#: core's buffer whole before the reply starts (so a failed read answers E10 alone).
READ_MAX = 16
#: The I2C addresses ``i2c_scan`` probes (0x00..0x07 and 0x78..0x7F are reserved).
SCAN_FIRST = 0x08
SCAN_LAST = 0x77
#: Probes of the EEPROM after a page write before the write cycle counts as hung:
#: each probe is ~11 bit times, so this covers the 24LC256's 5 ms at 400 kHz.
POLL_MAX = 250


class Code(IntEnum):
    """Error codes of the reply table (the number is the nn of ``Enn``)."""

    UNKNOWN = 1
    TOO_LONG = 2
    BAD_ARGUMENT = 3
    OUTSIDE_LIMITS = 4
    OVERFLOW = 5
    BAD_CHECKSUM = 6
    BUSY = 7
    NO_MOTION = 8
    IMAGE_INVALID = 9
    NO_ANSWER = 10
    CHECKSUM_REQUIRED = 11
    OVERRUN = 12
    BAD_CHARACTER = 13


#: The exact reply text of every error code (docs/protocol.md, "Replies").
ERROR_TEXT: dict[Code, str] = {
    Code.UNKNOWN: "E01 unknown command",
    Code.TOO_LONG: "E02 line too long",
    Code.BAD_ARGUMENT: "E03 bad argument",
    Code.OUTSIDE_LIMITS: "E04 outside limits",
    Code.OVERFLOW: "E05 speed/angle overflow",
    Code.BAD_CHECKSUM: "E06 bad checksum",
    Code.BUSY: "E07 busy",
    Code.NO_MOTION: "E08 no such motion",
    Code.IMAGE_INVALID: "E09 motion image invalid",
    Code.NO_ANSWER: "E10 no answer on i2c",
    Code.CHECKSUM_REQUIRED: "E11 checksum required",
    Code.OVERRUN: "E12 input overrun",
    Code.BAD_CHARACTER: "E13 bad character",
}

OK_LINE = b"OK\r\n"
#: Reply lines (terminator included) by code, precomputed for the core.
ERROR_LINE: dict[Code, bytes] = {c: t.encode() + EOL for c, t in ERROR_TEXT.items()}
#: Notice lines (``!`` + error text) by code.
NOTICE_LINE: dict[Code, bytes] = {c: b"!" + t.encode() + EOL for c, t in ERROR_TEXT.items()}


def image_state(image_ok: bool, crc: int = 0) -> str:
    """``ok crc=HHHH`` (the valid image's CRC-16, upper-case hex) or ``bad``."""
    return f"ok crc={crc:04X}" if image_ok else "bad"


def ready_line(image_ok: bool, crc: int = 0, build: str | None = None) -> bytes:
    """``!READY``; ``build`` is the firmware's build id (``build=``, last)."""
    return (f"!READY {PROTOCOL_NAME} image={image_state(image_ok, crc)}"
            + (f" build={build}" if build is not None else "")).encode() + EOL


def reaction_line(name: str) -> bytes:
    return f"!R {name}".encode() + EOL


def held_reaction_line(name: str) -> bytes:
    """Reaction ``name`` would have fired, but the reactions are held (``h1``)."""
    return f"!H {name}".encode() + EOL


def ok_line(data: str | None = None) -> bytes:
    return OK_LINE if data is None else f"OK {data}".encode() + EOL


def version_data(servos: int, sensors: int, motions: int, image_ok: bool,
                 checksum: bool, robot_id: str | None = None, crc: int = 0,
                 build: str | None = None) -> str:
    """The ``v`` reply's data: ``image=ok crc=HHHH`` or ``image=bad``, then the firmware's
    ``build=`` id when given, then ``robot_id`` (esair_min.model.identity) as ``id=...``."""
    return (f"{PROTOCOL_NAME} servos={servos} sensors={sensors} motions={motions} "
            f"image={image_state(image_ok, crc)} checksum={'on' if checksum else 'off'}"
            + (f" build={build}" if build is not None else "")
            + (f" id={robot_id}" if robot_id is not None else ""))


def version_fields(data: str) -> dict[str, str]:
    """The ``key=value`` words of a ``v`` reply's data (``crc`` only with a valid image)."""
    return dict(w.split("=", 1) for w in data.split() if "=" in w)


# -- checksum -------------------------------------------------------------------------

def _bytes(data: str | bytes | bytearray) -> bytes:
    return data.encode("latin-1") if isinstance(data, str) else bytes(data)


def xor_checksum(data: str | bytes | bytearray) -> int:
    """XOR of every byte of ``data``."""
    x = 0
    for b in _bytes(data):
        x ^= b
    return x


def add_checksum(line: str) -> str:
    """``line`` with its ``*HH`` suffix: ``add_checksum("t") == "t*74"``."""
    return f"{line}*{xor_checksum(line):02X}"


# -- servo pairs ----------------------------------------------------------------------

def encode_pair(angle: int, speed: int) -> tuple[int, int]:
    """Registers ``2m``/``2m+1`` of a servo: ``(angle % 100, angle/100 + 10*speed)``."""
    if not 0 <= angle <= 999:
        raise ProtocolError(f"angle {angle} is outside 0..999")
    if not 0 <= speed <= MAX_SPEED:
        raise ProtocolError(f"speed {speed} is outside 0..{MAX_SPEED}")
    low, high = encoding.encode_pair(angle, speed)
    if not encoding.pair_fits(angle, speed):
        raise ProtocolError(f"speed {speed} with angle {angle} encodes to high byte "
                            f"{high}, more than {encoding.PAIR_HIGH_MAX}")
    return low, high


def decode_pair(low: int, high: int) -> tuple[int, int]:
    """``(angle, speed)`` of a register pair; ``low`` must be below 100."""
    if not 0 <= low < 100 or not 0 <= high <= encoding.PAIR_HIGH_MAX:
        raise ProtocolError(f"pair ({low}, {high}) is not a servo encoding")
    return encoding.decode_pair(low, high)


# -- command lines (PAPA-MAN prefixes by default) ------------------------------------

def _letter(value: int, what: str, limit: int) -> str:
    if not 0 <= value < limit:
        raise ProtocolError(f"{what} {value} is outside 0..{limit - 1}")
    return chr(ord("a") + value)


def encode_motor(motor: int, speed: int, angle: int, prefix: str = "o") -> str:
    """``oMSAAA``: servo ``motor`` (0 = a) to ``angle`` with ``speed``."""
    if not 0 <= angle <= 999:
        raise ProtocolError(f"angle {angle} is outside 0..999")
    return f"{prefix}{_letter(motor, 'motor', 26)}{_letter(speed, 'speed', MAX_SPEED + 1)}{angle:03d}"


def encode_play(number: int, prefix: str = "PLY") -> str:
    if not 0 <= number <= 99:
        raise ProtocolError(f"motion number {number} is outside 0..99")
    return f"{prefix}{number:02d}"


def encode_speeds(speeds: Iterable[int], prefix: str = "a") -> str:
    out = [prefix]
    for s in speeds:
        if not 0 <= s <= MAX_SPEED:
            raise ProtocolError(f"speed {s} is outside 0..{MAX_SPEED}")
        out.append(f"{s:03d}")
    return "".join(out)


def angle_code(angle: int | None) -> str:
    """The ``c`` command's character for ``angle`` (``None`` keeps the target)."""
    if angle is None:
        return KEEP_CODE
    if not 0 <= angle <= 180 or angle % ANGLE_STEP:
        raise ProtocolError(f"angle {angle} is not a multiple of 3 in 0..180")
    return chr(ANGLE_CODE_FIRST + angle // ANGLE_STEP)


def encode_angles(angles: Sequence[int | None], prefix: str = "c") -> str:
    return prefix + "".join(angle_code(a) for a in angles)


def encode_stand(prefix: str = "t") -> str:
    return prefix


def encode_version(prefix: str = "v") -> str:
    return prefix


def encode_sensors(prefix: str = "s") -> str:
    return prefix


def encode_stop(prefix: str = "x") -> str:
    return prefix


def chunk_checksum(address: int, data: bytes | bytearray) -> int:
    """The byte that makes the address's two bytes, the data and itself sum to 0 (mod 256)."""
    return -((address >> 8) + (address & 0xFF) + sum(data)) & 0xFF


def encode_image_write(address: int, data: bytes | bytearray, prefix: str = "w") -> str:
    """``wAAAA<data hex><checksum hex>``: write ``data`` at image ``address``."""
    if not 0 <= address <= 0xFFFF:
        raise ProtocolError(f"address {address} is outside 0..65535")
    if not data:
        raise ProtocolError("a chunk needs at least one byte")
    return (f"{prefix}{address:04X}{bytes(data).hex().upper()}"
            f"{chunk_checksum(address, data):02X}")


def encode_image_read(address: int, count: int, prefix: str = "r") -> str:
    """``rAAAANN``: read ``count`` bytes (1..READ_MAX) of the EEPROM from ``address``."""
    if not 0 <= address <= 0xFFFF:
        raise ProtocolError(f"address {address} is outside 0..65535")
    if not 1 <= count <= READ_MAX:
        raise ProtocolError(f"count {count} is outside 1..{READ_MAX}")
    return f"{prefix}{address:04X}{count:02X}"


def decode_image_read(address: int, data: str) -> bytes:
    """The bytes of a read's ``OK`` data (hex bytes, then the checksum byte)."""
    try:
        raw = bytes.fromhex(data)
    except ValueError:
        raise ProtocolError(f"not hex bytes: {data!r}") from None
    if len(raw) < 2 or chunk_checksum(address, raw[:-1]) != raw[-1]:
        raise ProtocolError(f"bad checksum in the read reply {data!r}")
    return raw[:-1]


def frame_line(line: str, checksum: bool = False) -> bytes:
    """A command line ready for the wire: optional checksum, CR LF."""
    return (add_checksum(line) if checksum else line).encode("ascii") + EOL


# -- replies --------------------------------------------------------------------------

class Reply(NamedTuple):
    """One line from the board. ``kind`` is ``ok``, ``error`` or ``notice``. (A named
    tuple, not a dataclass: ``dataclasses`` imports ``inspect`` and ``ast`` into the
    robot side, whose link parses every reply with this module.)"""

    kind: str
    code: Code | None = None   # for errors and error notices
    data: str = ""             # after "OK " or after "!"

    @property
    def counts(self) -> bool:
        """True if this line answers a command (notices do not)."""
        return self.kind != "notice"


_BY_TEXT = {t: c for c, t in ERROR_TEXT.items()}


def parse_reply(line: str | bytes) -> Reply:
    """Parse one line the board sent (terminator optional)."""
    text = line.decode("ascii", "replace") if isinstance(line, (bytes, bytearray)) else line
    text = text.rstrip("\r\n")
    if text.startswith("!"):
        body = text[1:]
        return Reply("notice", _BY_TEXT.get(body), body)
    if text == "OK":
        return Reply("ok")
    if text.startswith("OK "):
        return Reply("ok", None, text[3:])
    code = _BY_TEXT.get(text)
    if code is None:
        raise ProtocolError(f"not a reply line: {text!r}")
    return Reply("error", code, text)


def velocity_line(vx: int, vy: int, omega: int) -> str:
    """An omni base's command line for a body velocity (mm/s, mm/s, mrad/s)."""
    return "V" + "".join(f"{v:+05d}" for v in (vx, vy, omega))
