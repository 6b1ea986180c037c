"""The numbers of ESAIR's PIC18F452 serial bootloader (docs/bootloader.md): where it lives,
where the application goes, its line speed and timing. The generator puts them in the
bootloader's assembly, the flasher (esair_min.flash.pic) speaks to it with them."""

from __future__ import annotations

import binascii

from esair_min.model import hardware

VERSION = 1
BOOT_BAUD = 115200
BOOT_END = 0x0200            # boot block 0x0000..0x01FF (the part's 512-byte boot block)
APP_START = BOOT_END         # the application's reset vector; its interrupt vectors +8, +0x18
RECORD = 0x7FC0              # the last 64-byte row: the application's record, written last
FLASH_END = 0x8000
ROW = 64                     # erase row
BLOCK = 8                    # write block
EEPROM_BYTES = 256
DEVICE_ID = 0x0420           # PIC18F452: DEVID2 0x04, DEVID1 bits 7..5 = 001 (rev in 4..0)
DEVICE_ID_MASK = 0xFFE0
#: the hello window after reset, and the gap that ends a frame, in milliseconds (goals;
#: the bootloader counts in units of ``unit_ms``)
WINDOW_MS = 300
GAP_MS = 60
#: polling loop: 256 x 256 passes of 5 instruction cycles, plus 4 per outer pass
UNIT_CYCLES = 256 * (256 * 5 + 4)


def board_tag(robot: str, role: str) -> int:
    """16 bits naming the robot and board a bootloader was generated for (CRC-32, low half)."""
    return binascii.crc32(f"{robot}/{role}".encode()) & 0xFFFF


def unit_ms(clock_hz: int) -> float:
    return UNIT_CYCLES * 4 * 1000 / clock_hz


def boot_context(robot: str, role: str, clock_hz: int) -> dict[str, object]:
    """What the bootloader's template needs."""
    baud = hardware.best_baud(clock_hz, BOOT_BAUD)
    unit = unit_ms(clock_hz)
    return {"baud": BOOT_BAUD, "spbrg": baud.spbrg, "brgh": baud.brgh,
            "error_percent": round(baud.error_percent, 2),
            "window_units": max(1, round(WINDOW_MS / unit)),
            "byte_units": max(1, round(GAP_MS / unit)),
            "unit_ms": round(unit, 1), "version": VERSION,
            "tag": board_tag(robot, role)}


def app_end(addresses: list[int]) -> int:
    """The end of an application (its last row's end): the rows 0x0200..end are written
    whole, gaps as 0xFF, so the bootloader's sum covers known bytes on any chip."""
    top = max(a for a in addresses if APP_START <= a < RECORD)
    return (top // ROW + 1) * ROW


def app_sum(flash: bytes | bytearray, end: int) -> int:
    """The 16-bit sum of ``flash[APP_START:end]`` (``flash`` indexed from address 0)."""
    return sum(flash[APP_START:end]) & 0xFFFF


def record(end: int, total: int, tag: int) -> bytes:
    """The record row: 'E', end, sum (big-endian), the board's tag, the version; 0xFF after."""
    head = bytes([ord("E"), end >> 8, end & 0xFF, total >> 8, total & 0xFF,
                  tag >> 8, tag & 0xFF, VERSION])
    return head + b"\xff" * (ROW - len(head))
