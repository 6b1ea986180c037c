"""A PIC18F452 in gpsim behind a pty: its UART is a serial port any program opens.

gpsim runs interactively (:class:`esair_min.pic.gpsim_i2c.GpsimSession`) with the
``usart`` module on RC6/RC7. A thread moves the simulation on in slices paced to the
wall clock (``speed`` simulated seconds per second): the bytes a program wrote to the
pty go into the module's transmit FIFO (``U1.tx``) and reach the PIC at line rate; every
write of TXREG (gpsim's register log) goes back out of the pty. The line follows the
baud rate the program set on the pty (as a real line must match the PIC's), and
:meth:`GpsimPty.fault` cuts or damages it for the fault tests. docs/bootloader.md.
"""

from __future__ import annotations

import os
import termios
import threading
import time
import tty
from pathlib import Path

from esair_min.pic.gpsim_i2c import GpsimSession
from esair_min.pic.gpsim_line import SETUP, TX_RE, LineFault
from esair_min.pic.toolchain import ToolchainError

_SPEEDS = {getattr(termios, f"B{b}"): b for b in
           (1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200, 230400)}
SLICE = 50_000            # most instruction cycles run in one batch (10 ms at 20 MHz)


class GpsimPty:
    """Start with :meth:`start`; :attr:`path` is the pty a program opens."""

    def __init__(self, workdir: Path, cod: Path, clock_hz: int, speed: float = 1.0,
                 timeout: float = 300.0, eeprom: bool = False):
        self.workdir = Path(workdir)
        self.cod = Path(cod)
        self.clock_hz = clock_hz
        self.speed = speed
        self.timeout = timeout
        self.eeprom = eeprom              # a 24LC256 at 0x50 on the I2C bus (the motions')
        self.path = ""
        self.sent = 0                     # bytes the program has sent
        self.error: Exception | None = None
        self._fault: LineFault | None = None
        self._cmds: list[str] = []
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._session: GpsimSession | None = None
        self._master = self._slave = -1
        self._baud = 0
        self._logbuf = ""

    def start(self) -> GpsimPty:
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        os.set_blocking(self._master, False)
        self.path = os.ttyname(self._slave)
        log = self.workdir / "uart.log"
        log.unlink(missing_ok=True)
        s = GpsimSession(self.workdir, timeout=self.timeout).start(self.cod, self.clock_hz)
        self._session = s
        s.command(*SETUP, f"log on {log}", "log w 0xFAD")
        if self.eeprom:
            s.command("module load e24xx256 EE", "attach nscl EE.SCL", "attach nsda EE.SDA")
        self._follow_baud()
        self._log = open(log, "rb")     # noqa: SIM115 (closed in close())
        self._thread = threading.Thread(target=self._run, name="gpsim-pty", daemon=True)
        self._thread.start()
        return self

    def fault(self, fault: LineFault | None) -> None:
        """From now on, what happens to the bytes the program sends."""
        with self._lock:
            self._fault = fault

    def command(self, *lines: str) -> None:
        """gpsim commands sent before the next slice (``reset``: a reset)."""
        with self._lock:
            self._cmds += lines

    @property
    def cycles(self) -> int:
        return self._session.now if self._session else 0

    def _follow_baud(self) -> None:
        speed = _SPEEDS.get(termios.tcgetattr(self._slave)[5], 9600)
        if speed != self._baud and self._session is not None:
            self._session.command(f"U1.txbaud = {speed}", f"U1.rxbaud = {speed}")
            self._baud = speed

    def _take(self) -> bytes:
        try:
            data = os.read(self._master, 4096)
        except BlockingIOError:
            return b""
        except OSError:                   # no program has the pty open
            return b""
        with self._lock:
            self.sent += len(data)
            return self._fault.apply(data) if self._fault else data

    def _run(self) -> None:
        s = self._session
        assert s is not None
        rate = self.clock_hz / 4 * self.speed
        t0, c0 = time.monotonic(), s.now
        try:
            while not self._stop.is_set():
                self._follow_baud()
                data = self._take()
                with self._lock:
                    cmds, self._cmds = self._cmds, []
                want = c0 + int((time.monotonic() - t0) * rate)
                if want < s.now + 1000 and not data and not cmds:
                    time.sleep(0.001)
                    continue
                target = min(max(want, s.now + 1000), s.now + SLICE)
                s.run_to(target, *cmds, *(f"U1.tx = {b:#04x}" for b in data))
                text = self._logbuf + self._log.read().decode("latin-1")
                cut = text.rfind("\n") + 1
                self._logbuf = text[cut:]
                out = bytes(int(m.group(1), 16) & 0xFF for m in TX_RE.finditer(text[:cut]))
                if out:
                    try:
                        os.write(self._master, out)
                    except OSError:
                        pass
        except (ToolchainError, OSError) as exc:   # gpsim died: seen in .error
            self.error = exc

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=30)
        if self._session is not None:
            self._session.close()
        for fd in (self._master, self._slave):
            if fd >= 0:
                os.close(fd)
        self._master = self._slave = -1
        if getattr(self, "_log", None) is not None:
            self._log.close()

    def __enter__(self) -> GpsimPty:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()


def main(argv: list[str] | None = None) -> int:
    """``python -m esair_min.pic.gpsim_pty BOARD_DIR``: a board's bootloader (from
    ``esair build``) in gpsim behind a pty, until Ctrl-C or SIGTERM; prints the pty."""
    import argparse
    import signal
    import tempfile

    ap = argparse.ArgumentParser(prog="python -m esair_min.pic.gpsim_pty",
                                 description=main.__doc__)
    ap.add_argument("board_dir", type=Path, help="a built board folder (build/ROBOT/ROLE)")
    ap.add_argument("--clock", type=int, default=20_000_000, help="the board's clock in Hz")
    ap.add_argument("--eeprom", action="store_true",
                    help="a blank 24LC256 at 0x50 on the I2C bus, for the motions")
    ns = ap.parse_args(argv)
    cod = ns.board_dir / "build-boot" / "bootloader.cod"
    if not cod.is_file():
        print(f"error: {cod} not found: run esair build first", flush=True)
        return 1
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    with tempfile.TemporaryDirectory() as tmp, GpsimPty(Path(tmp), cod, ns.clock, eeprom=ns.eeprom) as g:
        print(f"pty: {g.path}", flush=True)
        try:
            while not stop.wait(0.2) and g.error is None:
                pass
        except KeyboardInterrupt:
            pass
        if g.error is not None:
            print(f"error: gpsim: {g.error}", flush=True)
            return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
