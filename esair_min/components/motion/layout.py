"""Where each motion lives in the EEPROM image (docs/eeprom-format.md).

Layout only (sizes and offsets, needed by validation to say "EEPROM too small");
the bytes themselves are built by :mod:`esair_min.core.image`.
"""

from __future__ import annotations

from dataclasses import dataclass
from collections.abc import Sequence

from esair_min.components.motion.schema import Motion

MAGIC = b"EM"
VERSION = 2            # 2: a directory entry names its servo count (was reserved, 0)
HEADER_BYTES = 8       # magic(2) version(1) count(1) length(u16 LE) crc16(u16 LE)
DIR_ENTRY_BYTES = 6    # number(1) frames(1) delay_ticks(1) servos(1) offset(u16 LE)


@dataclass(frozen=True)
class MotionSlot:
    number: int
    name: str
    frames: int
    delay_ticks: int
    offset: int        # of the first frame, from the start of the image
    frame_bytes: int


@dataclass(frozen=True)
class ImageLayout:
    servos: int
    slots: tuple[MotionSlot, ...]
    total_bytes: int

    @property
    def frame_bytes(self) -> int:
        return 2 * self.servos


def image_layout(motions: Sequence[Motion], servos: int) -> ImageLayout:
    """Motions sorted by number; frames follow the directory back to back."""
    ordered = sorted(motions, key=lambda m: m.number)
    offset = HEADER_BYTES + DIR_ENTRY_BYTES * len(ordered)
    slots = []
    for m in ordered:
        slots.append(MotionSlot(m.number, m.name, len(m.frames), m.delay_ticks, offset, 2 * servos))
        offset += len(m.frames) * 2 * servos
    return ImageLayout(servos, tuple(slots), offset)
