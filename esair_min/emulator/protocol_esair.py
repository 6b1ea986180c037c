"""pySerial URL handler: ``esair://ROBOT[?option=value&...]`` is an emulated robot.

::

    import serial
    import esair_min.emulator          # registers the esair:// scheme with pySerial
    port = serial.serial_for_url("esair://boards/papaman?scenario=push", timeout=1)
    port.write(b"v\\r\\n")
    print(port.readline())

The emulator runs in-process, without threads: it is advanced whenever the port is
used. Options:

- ``speed=real`` (default): virtual time follows the wall clock, as a real robot;
  ``speed=<factor>`` (e.g. ``10``) runs that many times faster than the wall clock;
  ``speed=max``: as fast as possible: virtual time advances only while the program
  waits on the port (``read`` waits up to its timeout in *virtual* seconds, 60 when
  the timeout is None; ``in_waiting`` runs until the robot has answered every byte
  written, and at least one tick);
- ``scenario=NAME|FILE``: sensor readings over time (docs/emulator.md);
- ``trace=FILE``: write the event trace (docs/trace-format.md);
- ``nack=actuator``, ``absent=sensor``, ``corrupt=eeprom``, ``noise=<bytes/s>``,
  ``seed=<n>``: faults (:class:`~.faults.Faults`);
- ``eeprom=blank``: the EEPROM starts blank (no motion image: ``esair eeprom --write``);
  ``eeprom=FILE``: the EEPROM's contents live in FILE (``esair emulate --eeprom``).

The port's baud rate setting is ignored: bytes travel at the robot's declared baud.
"""

from __future__ import annotations

import threading
import time
import urllib.parse
from pathlib import Path

from serial.serialutil import PortNotOpenError, SerialBase, SerialException
from serial.serialutil import to_bytes  # type: ignore[attr-defined]  # pyserial has it; its stubs do not

from esair_min.errors import EsairError
from esair_min.emulator.clock import NS_PER_S, seconds_to_ns
from esair_min.emulator.faults import Faults
from esair_min.emulator.pacing import Pacer
from esair_min.emulator.papaman.robot_sim import Emulator

SCHEME = "esair://"
MAX_BLOCK_S = 60.0        # virtual seconds a read with timeout=None waits at speed=max
OPTIONS = ("speed", "scenario", "trace", "nack", "absent", "corrupt", "stuck", "noise", "seed",
           "eeprom")


def parse_url(url: str) -> tuple[str, dict[str, str]]:
    """(robot path, options) of an ``esair://`` URL."""
    if not url.lower().startswith(SCHEME):
        raise SerialException(f"expected a URL of the form esair://ROBOT[?option=value...], "
                              f"got {url!r}")
    rest = url[len(SCHEME):]
    robot, _, query = rest.partition("?")
    if not robot:
        raise SerialException("esair:// URL names no robot (e.g. esair://boards/papaman)")
    opts: dict[str, str] = {}
    for key, values in urllib.parse.parse_qs(query, keep_blank_values=True).items():
        if key not in OPTIONS:
            raise SerialException(f"unknown option {key!r} in {url!r} "
                                  f"(known: {', '.join(OPTIONS)})")
        opts[key] = values[-1]
    return urllib.parse.unquote(robot), opts


def _faults(opts: dict[str, str]) -> Faults:
    checks = {"nack": "actuator", "absent": "sensor", "corrupt": "eeprom", "stuck": "bus"}
    for key, want in checks.items():
        if key in opts and opts[key] != want:
            raise SerialException(f"option {key}={opts[key]!r}: only {key}={want} exists")
    try:
        noise = float(opts.get("noise", "0"))
        seed = int(opts.get("seed", "0"))
    except ValueError as exc:
        raise SerialException(f"bad number in URL options: {exc}") from None
    return Faults(actuator_nack="nack" in opts, sensor_absent="absent" in opts,
                  corrupt_eeprom="corrupt" in opts, noise_per_s=noise, seed=seed,
                  bus_stuck="stuck" in opts)


class Serial(SerialBase):
    """A serial port whose other end is an emulated robot."""

    # set by SerialBase (pySerial's own port classes use them too); not in its stubs
    _port: str | None
    _timeout: float | None

    def __init__(self, *args, **kwargs):
        self.emulator: Emulator | None = None
        self._pacer: Pacer | None = None
        self._max = False
        self._rx = bytearray()
        self._trace_file = None
        self._cancel = threading.Event()
        # one reader and one writer thread may use the port at once, as with pySerial's
        # POSIX ports: every call into the emulator holds this lock (a read's wait does not)
        self._emu_lock = threading.Lock()
        super().__init__(*args, **kwargs)

    # -- opening and closing -------------------------------------------------------------
    def open(self) -> None:
        if self.is_open:
            raise SerialException("Port is already open.")
        if self._port is None:
            raise SerialException("Port must be configured before it can be used.")
        robot_arg, opts = parse_url(self._port)
        speed = opts.get("speed", "real")
        factor = 1.0
        if speed == "max":
            self._max = True
        elif speed != "real":
            try:
                factor = float(speed)
            except ValueError:
                factor = 0.0
            if not factor > 0:
                raise SerialException(f"speed={speed!r}: use real, max or a factor > 0")
        from esair_min.resources import resolve_robot
        from esair_min.core.trace import TraceWriter
        from esair_min.model.validate import load_robot
        faults = _faults(opts)
        try:
            robot = load_robot(resolve_robot(robot_arg))
            trace = None
            if "trace" in opts:
                self._trace_file = open(opts["trace"], "w", encoding="ascii")  # noqa: SIM115  (closed with the port)
                trace = TraceWriter(self._trace_file, keep=False)
            eeprom = opts.get("eeprom")
            self.emulator = Emulator(robot, scenario=opts.get("scenario"),
                                     faults=faults, trace=trace,
                                     eeprom_image=b"" if eeprom == "blank" else None,
                                     eeprom_file=Path(eeprom) if eeprom not in (None, "blank")
                                     else None)
        except (EsairError, OSError) as exc:
            if self._trace_file is not None:
                self._trace_file.close()
                self._trace_file = None
            raise SerialException(f"cannot start the emulator: {exc}") from None
        self.emulator.settle()      # booted (image checked, !READY sent) before use
        self._pacer = None if self._max else Pacer(self.emulator, factor)
        self._rx.clear()
        self.is_open = True

    def close(self) -> None:
        if self.is_open and self.emulator is not None:
            with self._emu_lock:
                self.emulator.close()
            if self._trace_file is not None:
                self._trace_file.close()
                self._trace_file = None
        self.is_open = False

    def _reconfigure_port(self, *args, **kwargs) -> None:
        """Baud rate, parity... are accepted and ignored (the robot's line rate rules)."""

    # -- time ----------------------------------------------------------------------------
    def _pull(self) -> None:
        assert self.emulator is not None
        with self._emu_lock:
            if self._pacer is not None:
                self._pacer.sync()
            self._rx += self.emulator.read()

    def _advance_max(self, until_ns: int) -> None:
        emu = self.emulator
        assert emu is not None
        with self._emu_lock:
            nxt = emu.next_event_ns()
            t = until_ns if nxt is None else min(max(nxt, emu.clock.now), until_ns)
            emu.run_until(t)
            self._rx += emu.read()

    # -- the port API --------------------------------------------------------------------
    @property
    def in_waiting(self) -> int:
        if not self.is_open:
            raise PortNotOpenError()
        if self._max:
            emu = self.emulator
            assert emu is not None
            with self._emu_lock:
                emu.run_for(emu.tick_s)
                emu.settle()
                self._rx += emu.read()
        else:
            self._pull()
        return len(self._rx)

    def read(self, size: int = 1) -> bytes:
        if not self.is_open:
            raise PortNotOpenError()
        emu = self.emulator
        assert emu is not None
        timeout = self._timeout
        if self._max:
            wait = MAX_BLOCK_S if timeout is None else timeout
            with self._emu_lock:
                end = emu.clock.now + seconds_to_ns(wait)
                self._rx += emu.read()
            while len(self._rx) < size and emu.clock.now < end:
                self._advance_max(end)
        else:
            assert self._pacer is not None
            deadline = None if timeout is None else time.monotonic() + timeout
            self._pull()
            while len(self._rx) < size:
                left = None if deadline is None else deadline - time.monotonic()
                if left is not None and left <= 0:
                    break
                with self._emu_lock:
                    nap = self._pacer.wall_until_next(0.01)
                if self._cancel.wait(max(1e-4, nap if left is None else min(nap, left))):
                    break
                self._pull()
            self._cancel.clear()
        out = bytes(self._rx[:size])
        del self._rx[:size]
        return out

    def cancel_read(self) -> None:
        """End a ``read`` waiting in another thread now, with what it has (as pySerial's
        POSIX ports do; called before the read, it ends the next one at once)."""
        self._cancel.set()

    def write(self, data) -> int:
        if not self.is_open:
            raise PortNotOpenError()
        data = to_bytes(data)
        assert self.emulator is not None
        with self._emu_lock:
            if self._pacer is not None:
                self._pacer.sync()
            self.emulator.write(data)
        return len(data)

    def flush(self) -> None:
        """Wait until every byte written has left the host (at line rate)."""
        if not self.is_open:
            raise PortNotOpenError()
        emu = self.emulator
        assert emu is not None
        if self._max:
            with self._emu_lock:
                emu.run_until(emu.uart.rx_free_ns)
        else:
            with self._emu_lock:
                left = (emu.uart.rx_free_ns - emu.clock.now) / NS_PER_S
            if left > 0:
                time.sleep(left / (self._pacer.factor if self._pacer else 1.0))
        if not self._max:
            self._pull()

    def reset_input_buffer(self) -> None:
        if not self.is_open:
            raise PortNotOpenError()
        assert self.emulator is not None
        with self._emu_lock:
            if self._pacer is not None:
                self._pacer.sync()
            self.emulator.read()
        self._rx.clear()

    def reset_output_buffer(self) -> None:
        if not self.is_open:
            raise PortNotOpenError()

    @property
    def out_waiting(self) -> int:
        return 0

    # modem lines: a three-wire link, always asserted
    def _update_break_state(self) -> None:
        pass

    def _update_rts_state(self) -> None:
        pass

    def _update_dtr_state(self) -> None:
        pass

    @property
    def cts(self) -> bool:
        return True

    @property
    def dsr(self) -> bool:
        return True

    @property
    def ri(self) -> bool:
        return False

    @property
    def cd(self) -> bool:
        return True
