"""The numbers the board model, the Python cores, the generator and the tests share,
defined once (docs/protocol.md): the limits of a command line and the thesis's servo
register pair. No imports: the protocol module, ESAIR STD's link and the generated C's
context all read these without loading the pydantic model.
"""

from __future__ import annotations

#: Characters of a command line, terminator excluded, checksum suffix included.
MAX_LINE = 40
#: The checksum suffix ``*HH``.
CHECKSUM_CHARS = 3
#: The high byte of a servo's register pair is one byte.
PAIR_HIGH_MAX = 255


def encode_high(angle: int, speed: int) -> int:
    """The thesis's high byte: ``angle/100 + 10*speed``. It may exceed a byte: a caller
    checks it with :func:`pair_fits` (E05, a validator error, an image error)."""
    return angle // 100 + 10 * speed


def encode_pair(angle: int, speed: int) -> tuple[int, int]:
    """The register pair (low, high) of ``angle`` at ``speed``: ``angle % 100`` and
    :func:`encode_high` (unchecked: high may exceed 255)."""
    return angle % 100, encode_high(angle, speed)


def pair_fits(angle: int, speed: int) -> bool:
    """Whether ``angle`` at ``speed`` fits the pair's high byte."""
    return encode_high(angle, speed) <= PAIR_HIGH_MAX


def max_speed_at(angle: int) -> int:
    """The fastest speed whose pair with ``angle`` fits the high byte."""
    return (PAIR_HIGH_MAX - angle // 100) // 10


def decode_pair(low: int, high: int) -> tuple[int, int]:
    """``(angle, speed)`` of a register pair (unchecked)."""
    return (high % 10) * 100 + low, high // 10
