"""The emulated 24LC256: its write cycle in virtual time, and its contents in a file.

- :class:`CyclingEeprom` wraps the chip (:class:`~esair_min.core.devices.Eeprom24`) on
  the bus: after an acknowledged page write it acknowledges nothing for the chip's
  write cycle (``T_WC_NS``), so the central core's ACK polling takes as many probes as
  on the board. Time is the bus's: a transaction starts at the bus cursor.
- :func:`attach_file` keeps the chip's bytes in a file (raw, the chip's size): each
  page write goes to the file at once, so an emulator killed at any moment leaves what
  a real chip would keep after a power cut (``esair emulate --eeprom FILE``).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Callable

from esair_min.core.devices import Eeprom24
from esair_min.errors import EsairError
from esair_min.model.hardware import write_bits

#: The 24LC256's write cycle (datasheet: 5 ms at most), the one the emulator charges.
T_WC_NS = 5_000_000


class CyclingEeprom:
    """``chip`` on the bus with its write cycle: busy (no ACK) for :data:`T_WC_NS` after
    the STOP of each write that stored data."""

    def __init__(self, chip: Eeprom24, now: Callable[[], int], bit_ns: float):
        self.chip = chip
        self.address = chip.address
        self._now = now          # when the transaction being made starts
        self._bit_ns = bit_ns
        self.busy_until = 0
        self.cycles = 0          # page writes stored

    @property
    def fault(self) -> bool:
        return self.chip.fault

    def write(self, data: bytes) -> bool:
        t = self._now()
        if t < self.busy_until:
            return False
        ok = self.chip.write(data)
        if ok and len(data) > self.chip.address_bytes:
            self.busy_until = t + int(write_bits(len(data)) * self._bit_ns) + T_WC_NS
            self.cycles += 1
        return ok

    def write_read(self, wdata: bytes, n: int) -> bytes | None:
        if self._now() < self.busy_until:
            return None
        return self.chip.write_read(wdata, n)


def attach_file(chip: Eeprom24, path: Path) -> None:
    """Load ``chip`` from ``path`` (a missing or empty file: a blank chip, written
    out) and write every later store through to it."""
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError as exc:
        raise EsairError(f"cannot open the EEPROM file {path}: {exc.strerror}") from None
    size = os.fstat(fd).st_size
    if size not in (0, chip.size):
        os.close(fd)
        raise EsairError(f"the EEPROM file {path} has {size} bytes; the EEPROM has "
                         f"{chip.size} (use a new file: it starts blank)")
    if size == 0:
        chip.memory[:] = b"\xff" * chip.size
        os.pwrite(fd, bytes(chip.memory), 0)
    else:
        chip.memory[:] = os.pread(fd, chip.size, 0)

    def store(offset: int, data: bytes) -> None:
        os.pwrite(fd, data, offset)

    chip.on_store = store
