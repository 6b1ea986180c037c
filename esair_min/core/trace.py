"""Event traces (docs/trace-format.md): a writer and a bus wrapper that records."""

from __future__ import annotations

from typing import TYPE_CHECKING, TextIO

if TYPE_CHECKING:
    from esair_min.core.i2c_bus import Bus

HEADER = "# esair-trace 1"


class TraceWriter:
    """Collects trace lines (and writes each to ``stream`` if given).

    With ``keep=False`` lines are only written to ``stream`` (or dropped without
    one), and ``lines`` holds just the header: for long runs, whose whole trace would
    not fit in memory.

    UART output is buffered and becomes one ``TX`` line per complete line (ending
    in LF), however the sender split it."""

    #: also write ``RX`` lines (the emulator's ``--trace-rx``: the bytes its decoder took)
    rx_lines = False

    def __init__(self, stream: TextIO | None = None, keep: bool = True):
        self.stream = stream
        self.keep = keep
        self.lines: list[str] = [HEADER]
        self._tx = bytearray()
        self._rx = bytearray()
        self._rx_cr = False
        if stream is not None:
            stream.write(HEADER + "\n")
        if not keep:                    # the emitter chosen once, not tested per line
            self._emit = self._drop if stream is None else self._write  # type: ignore[method-assign]

    def _emit(self, line: str) -> None:
        self.lines.append(line)
        if self.stream is not None:
            self.stream.write(line + "\n")

    def _write(self, line: str) -> None:
        self.stream.write(line + "\n")  # type: ignore[union-attr]

    def _drop(self, line: str) -> None:
        pass

    def tick(self, n: int) -> None:
        self._emit(f"T {n}")

    def tx(self, data: bytes) -> None:
        for b in data:
            self._tx.append(b)
            if b == 0x0A:
                self._emit(f"TX {self._tx.hex().upper()}")
                self._tx.clear()

    def rx(self, data: bytes) -> None:
        """Bytes the decoder took, one ``RX`` line per line end, CR or LF (an LF right
        after a CR ends no line: CR LF counts once), the end included (only with
        ``rx_lines``)."""
        for b in data:
            if b == 0x0A and self._rx_cr and not self._rx:
                self._rx_cr = False
                continue
            self._rx.append(b)
            self._rx_cr = b == 0x0D
            if b in (0x0A, 0x0D):
                self._emit(f"RX {self._rx.hex().upper()}")
                self._rx.clear()

    def write(self, addr: int, data: bytes, ack: bool) -> None:
        self._emit(f"W {addr:02X} {bytes(data).hex().upper()} {'ACK' if ack else 'NACK'}")

    def probe(self, addr: int, ack: bool) -> None:
        """An address alone (START, address + W, STOP): ACK polling and i2c_scan."""
        self._emit(f"P {addr:02X} {'ACK' if ack else 'NACK'}")

    def read(self, addr: int, wdata: bytes, n: int, rdata: bytes | None) -> None:
        got = "NACK" if rdata is None else bytes(rdata).hex().upper()
        self._emit(f"R {addr:02X} {bytes(wdata).hex().upper()} {n} {got}")

    def mark(self, us: int) -> None:
        self._emit(f"@ {us}")

    def close(self) -> None:
        """Emit a pending partial UART line (none if every line was complete)."""
        if self._tx:
            self._emit(f"TX {self._tx.hex().upper()}")
            self._tx.clear()

    def text(self) -> str:
        return "".join(line + "\n" for line in self.lines)


class TracingBus:
    """A :class:`Bus` that records every transaction of ``bus`` in ``writer``."""

    def __init__(self, bus: Bus, writer: TraceWriter):
        self.bus = bus
        self.writer = writer

    def write(self, addr: int, data: bytes) -> bool:
        ack = self.bus.write(addr, data)
        if data:
            self.writer.write(addr, data, ack)
        else:
            self.writer.probe(addr, ack)
        return ack

    def write_read(self, addr: int, wdata: bytes, n: int) -> bytes | None:
        rdata = self.bus.write_read(addr, wdata, n)
        self.writer.read(addr, wdata, n, rdata)
        return rdata


def without_marks(lines: list[str] | str) -> list[str]:
    """Trace lines with ``@`` time marks removed (for comparisons)."""
    if isinstance(lines, str):
        lines = lines.splitlines()
    return [line for line in lines if not line.startswith("@ ")]
