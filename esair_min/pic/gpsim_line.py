"""A serial line to a PIC18F452 in gpsim, in simulated time (docs/bootloader.md).

:class:`SimLine` has the part of pySerial's port that :class:`esair_min.flash.pic.
Bootloader` uses (``write``, ``read`` with ``timeout``, ``reset_input_buffer``) plus
``clock``/``sleep`` in simulated seconds, so a flash runs exactly as over a real line
with a host that answers at once, deterministic and as fast as gpsim goes. ``write``
puts the bytes into the ``usart`` module's transmit FIFO (they reach RC7 at line rate),
``read`` runs the simulation on until the PIC has written enough bytes to TXREG (gpsim's
register log) or the timeout passes. :class:`LineFault` cuts or damages the line.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from esair_min.pic.gpsim_i2c import GpsimSession

TX_RE = re.compile(r"Wrote: 0x([0-9A-Fa-f]{4}) to \w+\(0x0FAD\)")
CYCLE_RE = re.compile(r"^0x([0-9A-Fa-f]{16}) p18f452 ")


@dataclass
class LineFault:
    """What happens to the bytes the host sends: after ``after`` more of them, ``cut``
    the line (nothing more arrives), or drop the next ``drop``, then XOR 0x20 into the
    next ``damage``."""

    after: int
    cut: bool = False
    drop: int = 0
    damage: int = 0

    def apply(self, data: bytes) -> bytes:
        out = bytearray()
        for b in data:
            if self.after > 0:
                self.after -= 1
            elif self.cut:
                continue
            elif self.drop > 0:
                self.drop -= 1
                continue
            elif self.damage > 0:
                self.damage -= 1
                b ^= 0x20
            out.append(b)
        return bytes(out)


SETUP = ("module load usart U1", "node ntx", "node nrx",
         "attach ntx portc6 U1.RXPIN", "attach nrx portc7 U1.TXPIN",
         "module load pullup PSCL", "module load pullup PSDA", "node nscl", "node nsda",
         "attach nscl portc3 PSCL.pin", "attach nsda portc4 PSDA.pin")


class SimLine:
    """The PIC's UART at ``baud``, in simulated time; ``session`` already started."""

    def __init__(self, session: GpsimSession, workdir: Path, clock_hz: int, baud: int):
        self.s = session
        self.rate = clock_hz / 4                 # instruction cycles per second
        self.timeout: float | None = 0.1         # simulated seconds, as pySerial's
        self.fault: LineFault | None = None
        self.sent = bytearray()                  # what reached the PIC's line
        self._log = Path(workdir) / "line.log"
        self._log.unlink(missing_ok=True)
        self._buf = bytearray()
        self._text = ""
        self._arrive = 0                         # the cycle the last byte sent is in
        self._cycle = 0
        self.tx_cycles: list[int] = []           # each TXREG write's cycle
        self.writes: list[tuple[int, bytes]] = []   # (first byte's cycle, bytes) per write
        session.command(*SETUP, f"log on {self._log}", "log w 0xFAD", "log r 0xFAE")
        self._fh = open(self._log, "rb")         # noqa: SIM115 (closed in close())
        self.baud = 0
        self.set_baud(baud)

    def set_baud(self, baud: int) -> None:
        self.s.command(f"U1.txbaud = {baud}", f"U1.rxbaud = {baud}")
        self.baud = baud
        self.byte_cycles = int(10 * self.rate / baud) + 1

    # -- simulated time --------------------------------------------------------------
    def clock(self) -> float:
        return self.s.now / self.rate

    def sleep(self, seconds: float) -> None:
        self.run_to(self.s.now + max(2, int(seconds * self.rate)))

    def run_to(self, cycle: int) -> None:
        self.s.run_to(cycle)
        self._collect()

    def _collect(self) -> None:
        text = self._text + self._fh.read().decode("latin-1")
        cut = text.rfind("\n") + 1
        self._text = text[cut:]
        for line in text[:cut].splitlines():
            if (c := CYCLE_RE.match(line)):
                self._cycle = int(c.group(1), 16)
            elif (m := TX_RE.search(line)):
                self._buf.append(int(m.group(1), 16) & 0xFF)
                self.tx_cycles.append(self._cycle)

    # -- pySerial's part ---------------------------------------------------------------
    def write(self, data: bytes) -> int:
        sent = self.fault.apply(data) if self.fault else bytes(data)
        self.sent += sent
        if sent:
            self.s.command(*(f"U1.tx = {b:#04x}" for b in sent))
            self.writes.append((max(self._arrive, self.s.now), sent))
            self._arrive = max(self._arrive, self.s.now) + len(sent) * self.byte_cycles
        return len(data)

    def reset_input_buffer(self) -> None:
        self._collect()
        self._buf.clear()

    def read(self, n: int = 1) -> bytes:
        """Up to ``n`` bytes, running the simulation until they came or ``timeout``."""
        timeout = self.timeout if self.timeout is not None else 3600.0
        deadline = self.s.now + int(timeout * self.rate)
        step = max(self._arrive - self.s.now, 0) + n * self.byte_cycles + 500
        while len(self._buf) < n and self.s.now < deadline:
            self.run_to(min(deadline, self.s.now + step))
            step = max(2 * step, (n - len(self._buf)) * self.byte_cycles + 500)
        out = bytes(self._buf[:n])
        del self._buf[:n]
        return out

    def close(self) -> None:
        self._fh.close()
