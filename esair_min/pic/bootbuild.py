"""``esair build``'s second PIC image: ESAIR's serial bootloader (gpasm) and the
application linked above it (docs/bootloader.md).

``make boot`` in a board folder assembles ``bootloader.hex`` and links the application
with its interrupt vectors at 0x0208/0x0218 and its code from 0x0208; SDCC's start-up
GOTO is still at 0x0000 (it comes from SDCC's precompiled crt0), so it is moved here to
0x0200, the application's reset vector, and the record (sum, board tag) is added at
0x7FC0: ``firmware-app.hex``, what ``esair flash`` writes through the bootloader.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from esair_min.errors import EsairError
from esair_min.make import make_board
from esair_min.model import picboot
from esair_min.pic.toolchain import Toolchain, ToolchainError, parse_map


class BootBuildError(EsairError):
    """The bootloader or the relocated application did not build, or does not fit."""


@dataclass(frozen=True)
class BootUsage:
    bootloader_bytes: int        # program bytes of bootloader.hex (boot block: <= 512)
    app_bytes: int               # the relocated application's program bytes (gplink map)
    app_end: int                 # the end of its last row (what the record's sum covers)

    def line(self, role: str) -> str:
        return (f"{role}: bootloader {self.bootloader_bytes} B of {picboot.BOOT_END} "
                f"(boot block); application above it {self.app_bytes} B "
                f"(0x{picboot.APP_START:04X}..0x{self.app_end - 1:04X}); "
                f"{picboot.BOOT_BAUD} baud (docs/bootloader.md)")


def has_bootloader(folder: Path) -> bool:
    return (folder / "ports" / "pic18f452" / "bootloader.asm").is_file()


def program_bytes(hex_path: Path) -> int:
    """Bytes an Intel hex file puts in program memory (config and EEPROM not counted)."""
    from intelhex import IntelHex

    return sum(1 for a in IntelHex(str(hex_path)).addresses() if a < picboot.FLASH_END)


def relocate(linked: Path, out: Path, tag: int) -> int:
    """``linked`` (the application linked above the bootloader) with its start-up GOTO
    moved from 0x0000 to 0x0200 and the record added: written to ``out``; its end."""
    from intelhex import IntelHex

    ih = IntelHex(str(linked))
    low = [a for a in ih.addresses() if a < picboot.APP_START]
    entry = [ih[a] for a in range(4)]
    if sorted(low) != [0, 1, 2, 3] or entry[1] != 0xEF or entry[3] & 0xF0 != 0xF0:
        raise BootBuildError(f"{linked}: expected only SDCC's start-up GOTO below "
                             f"0x{picboot.APP_START:04X}, found {len(low)} bytes there")
    if any(picboot.APP_START <= a < picboot.APP_START + 4 for a in ih.addresses()):
        raise BootBuildError(f"{linked}: 0x{picboot.APP_START:04X} is not free for the reset "
                             "vector (check ports/pic18f452/app18f452.lkr)")
    for i, b in enumerate(entry):
        del ih[i]
        ih[picboot.APP_START + i] = b
    end = add_record(ih, tag, str(linked))
    ih.write_hex_file(str(out))
    return end


def add_record(ih: Any, tag: int, name: str) -> int:
    """Put the record row (end, sum, board tag) into IntelHex ``ih``; the end."""
    if any(picboot.RECORD <= a < picboot.FLASH_END for a in ih.addresses()):
        raise BootBuildError(f"{name}: code in the record row 0x{picboot.RECORD:04X}")
    end = picboot.app_end(list(ih.addresses()))
    flash = bytearray(b"\xff" * picboot.FLASH_END)
    for a in ih.addresses():
        if a < picboot.FLASH_END:
            flash[a] = ih[a]
    rec = picboot.record(end, picboot.app_sum(flash, end), tag)
    for i, b in enumerate(rec):
        ih[picboot.RECORD + i] = b
    return end


def build_boot(folder: Path, tc: Toolchain, robot: str, role: str,
               timeout: float = 300.0) -> BootUsage:
    """``make -B boot`` in a generated board folder, then ``firmware-app.hex``."""
    make_board(folder, "boot", "PIC bootloader", BootBuildError, (f"PREFIX={tc.prefix}",),
               timeout)
    boot = program_bytes(folder / "bootloader.hex")
    if boot > picboot.BOOT_END:
        raise BootBuildError(f"{folder}: the bootloader is {boot} B, more than the "
                             f"{picboot.BOOT_END}-byte boot block")
    try:
        usage = parse_map(folder / "build-boot" / "firmware.map")
    except ToolchainError as exc:
        raise BootBuildError(str(exc)) from None
    end = relocate(folder / "build-boot" / "firmware.hex", folder / "firmware-app.hex",
                   picboot.board_tag(robot, role))
    return BootUsage(boot, usage.program_bytes, end)
