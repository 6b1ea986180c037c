"""Build a generated board folder for the ATmega328P with avr-gcc (``make -B atmega328p``).

Any warning is a failure (the Makefile passes ``-Werror`` too). The footprint comes
from the ELF's sections (``avr-size -A``): program memory = ``.text`` + ``.data``
(its initial values live in flash), RAM = ``.data`` + ``.bss`` + ``.noinit`` (the stack
comes on top, measured in the simulator).
"""

from __future__ import annotations

import re
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

from esair_min.errors import EsairError
from esair_min.make import make_board

FLASH_BYTES = 32768
RAM_BYTES = 2048
INSTALL_HINT = "run scripts/install-toolchain.sh (as root) to install it"


class AvrBuildError(EsairError):
    """avr-gcc is missing or a board's firmware did not build cleanly."""


@dataclass(frozen=True)
class AvrUsage:
    program_bytes: int
    data_bytes: int
    stack_bytes: int = 0          # not known from the ELF: see the simulator's figure


def avr_gcc() -> str:
    """The path of avr-gcc, or AvrBuildError saying how to install it."""
    path = shutil.which("avr-gcc")
    if path is None or shutil.which("avr-size") is None:
        raise AvrBuildError(f"ATmega328P toolchain not found (avr-gcc, avr-size); {INSTALL_HINT}")
    return path


def elf_usage(elf: Path) -> AvrUsage:
    """Flash and RAM bytes of a linked ELF, from ``avr-size -A``."""
    try:
        out = subprocess.run(["avr-size", "-A", str(elf)], capture_output=True, text=True,
                             timeout=30, check=True).stdout
    except (OSError, subprocess.SubprocessError) as exc:
        raise AvrBuildError(f"avr-size {elf} failed: {exc}") from None
    size = {m.group(1): int(m.group(2))
            for m in re.finditer(r"^(\.\w+)\s+(\d+)\s+\d+\s*$", out, re.M)}
    return AvrUsage(size.get(".text", 0) + size.get(".data", 0),
                    size.get(".data", 0) + size.get(".bss", 0) + size.get(".noinit", 0))


def build_board(folder: Path, timeout: float = 300.0) -> AvrUsage:
    """``make -B atmega328p`` in one generated board folder; the ELF's usage."""
    avr_gcc()
    make_board(folder, "atmega328p", "AVR", AvrBuildError, timeout=timeout)
    return elf_usage(folder / "firmware.elf")
