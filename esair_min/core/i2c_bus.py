"""The core's only hardware boundary: I2C master transactions.

The central core, the frame player and the trace recorder all take a :class:`Bus`;
the harness, the emulator and the tests supply one.
"""

from __future__ import annotations

from typing import Protocol


class Bus(Protocol):
    """The only hardware boundary of the core: I2C master transactions."""

    def write(self, addr: int, data: bytes) -> bool:
        """Write ``data`` to 7-bit address ``addr``; True if acknowledged."""
        ...

    def write_read(self, addr: int, wdata: bytes, n: int) -> bytes | None:
        """Write ``wdata``, repeated start, read ``n`` bytes; None if not acknowledged."""
        ...
