"""gpsim as a real I2C master to a PIC's slave firmware: an interactive session and a
bit-banged master on open-drain bus lines.

gpsim's ``i2cmaster`` module never moves SCL/SDA and gpsim runs one processor, so
nothing in gpsim can clock a slave firmware (docs/toolchain.md). Instead gpsim runs
interactively (``gpsim -i``, commands on stdin) and Python is the master: each bus
line is a node with a ``pullup`` module on it; ``P.voltage = 0.0`` pulls the line low,
``P.voltage = 5.0`` releases it (the PIC's own open-drain low still wins), and the
``portc`` command reads the pin levels, so the master sees the slave's ACKs, its data
and its clock stretching. Between two bus moves the simulation runs to an exact
instruction cycle (``break c N`` + ``run``), so the bus timing is exact to an
instruction (gpsim stops between instructions: 1 or 2 cycles).

:class:`GpsimSession` is the session (start, command, run_to, close; a wall-clock
deadline, the process always killed); :class:`I2cMaster` drives the bus with the
standard-mode (<= 100 kHz) or fast-mode (400 kHz) minimum times of the I2C
specification (UM10204, table 10), honours clock stretching (after releasing SCL it
waits, bounded, until SCL reads high, and records how long) and reports a line stuck
low as an error, never a hang. Stdlib only.
"""

from __future__ import annotations

import math
import os
import re
import select
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Self

from esair_min.pic.gpsim_harness import _gpsim_pin
from esair_min.pic.toolchain import _NOISE, Toolchain, ToolchainError, find_toolchain

_CYCLE_BREAK_RE = re.compile(r"cycle break: 0x[0-9a-fA-F]+ = (\d+)")
_CYCLES_RE = re.compile(r"^(\d+) = 0x[0-9A-Fa-f]+\s*$")
_VALUE_RE = re.compile(r"^\s*_?(\w+) = (0x[0-9a-fA-F]+|\d+)\s*$")


def _brief(lines: tuple[str, ...]) -> str:
    text = "; ".join(lines)
    return text if len(text) <= 200 else text[:200] + f"... ({len(lines)} commands)"


class GpsimSession:
    """``gpsim -i`` driven command by command (use as a context manager).

    Every command is followed by ``echo <marker>`` and its output is read up to that
    marker, without the "attempt write to invalid register" noise. ``timeout`` bounds
    the whole session in wall-clock seconds: when it expires, or gpsim exits, or a
    command is a syntax error, the process is killed and ToolchainError raised.
    """

    def __init__(self, workdir: str | os.PathLike[str], timeout: float = 60.0,
                 tc: Toolchain | None = None):
        self.workdir = Path(workdir)
        self.timeout = timeout
        self.tc = tc
        self.now = 0                 # the cycle the simulation stopped at
        self.batches = 0             # command batches sent (for the figures)
        self._proc: subprocess.Popen[bytes] | None = None
        self._buf = b""
        self._deadline = 0.0
        self._marker = 0

    def start(self, cod: str | os.PathLike[str], clock_hz: int) -> GpsimSession:
        """Start gpsim with firmware ``cod`` at ``clock_hz`` and the modules library."""
        tc = self.tc or find_toolchain()
        self.workdir.mkdir(parents=True, exist_ok=True)
        self._deadline = time.monotonic() + self.timeout
        # line-buffered (stdbuf): without it gpsim holds its answers in a pipe buffer
        self._proc = subprocess.Popen(["stdbuf", "-oL", "-eL", str(tc.gpsim), "-i"],
                                      stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                      stderr=subprocess.STDOUT, cwd=self.workdir)
        self.command(f"load {Path(cod).resolve()}",
                     "p18f452.BreakOnInvalidRegisterWrite = false",
                     f"frequency {clock_hz}", "module library libgpsim_modules.so.0")
        return self

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _fail(self, message: str, kill: bool = False) -> ToolchainError:
        self.close(kill)
        return ToolchainError(message)

    def command(self, *lines: str) -> list[str]:
        """Send commands as one batch; their output lines, without prompts and noise.
        A syntax error, gpsim exiting or the session's deadline raise ToolchainError."""
        proc = self._proc
        if proc is None:
            raise ToolchainError("gpsim session is not running")
        assert proc.stdin is not None and proc.stdout is not None   # started with pipes
        self._marker += 1
        self.batches += 1
        marker = f"ZZ{self._marker}ZZ".encode()
        try:
            proc.stdin.write("".join(f"{c}\n" for c in lines).encode()
                             + b"echo " + marker + b"\n")
            proc.stdin.flush()
        except OSError:                       # it exited: its output tells why
            pass
        fd = proc.stdout.fileno()
        end = b"\n" + marker + b"\n"
        while True:
            if self._buf.startswith(marker + b"\n"):
                text, self._buf = b"", self._buf[len(marker) + 1:]
                break
            at = self._buf.find(end)
            if at >= 0:
                text, self._buf = self._buf[:at], self._buf[at + len(end):]
                break
            left = self._deadline - time.monotonic()
            ready = select.select([fd], [], [], left)[0] if left > 0 else []
            chunk = os.read(fd, 65536) if ready else b""
            if not chunk:
                what = "exited" if ready else f"timed out after {self.timeout} s"
                tail = self._buf.decode("latin-1").splitlines()[-12:]
                raise self._fail(f"gpsim {what} during: {_brief(lines)}\n" + "\n".join(tail),
                                 kill=True)
            self._buf += chunk
        out = [x for x in text.decode("latin-1").splitlines()
               if not x.startswith(_NOISE) and not x.startswith("**gpsim>")]
        bad = [x for x in out if "***ERROR" in x]
        if bad:
            raise self._fail(f"gpsim rejected a command ({_brief(lines)}): {bad[0]}")
        return out

    def run_plan(self, plan: list[tuple[int, tuple[str, ...]]],
                 before: tuple[str, ...] = ()) -> list[tuple[int, list[str]]]:
        """One batch: ``before``, then for each ``(cycle, commands)`` run on to ``cycle``
        and send ``commands``. Returns (cycle stopped at, the commands' output) per step.

        gpsim stops only between instructions, so a stop lands on ``cycle`` or one past
        it (a 2-cycle instruction); the cycle is read back with ``cycles``. A cycle less
        than 2 after the previous one runs nothing (gpsim ignores a break that has gone
        by and would then ``run`` forever): its commands go with the previous stop."""
        batch, last = list(before), self.now
        targets: list[int] = []
        for cycle, commands in plan:
            if cycle >= last + (2 if targets else 1):
                batch += [f"break c {cycle}", "run", "cycles"]
                targets.append(cycle)
                last = cycle
            batch += ["echo @@", *commands]
        out = self.command(*batch)
        stops = [int(m.group(1)) for line in out if (m := _CYCLE_BREAK_RE.search(line))]
        steps = self._marked(out)
        if stops != targets or len(steps) != len(plan):
            raise self._fail(f"gpsim did not stop where expected (cycles {targets}):\n"
                             + "\n".join(out[-10:]))
        return steps

    def _marked(self, out: list[str]) -> list[tuple[int, list[str]]]:
        """Output split at each ``echo @@`` marker: (the cycle then, the lines up to the
        next marker); every ``cycles`` line moves :attr:`now`."""
        marked: list[tuple[int, list[str]]] = []
        for line in out:
            if _CYCLE_BREAK_RE.search(line):
                continue
            if (c := _CYCLES_RE.match(line)):
                self.now = int(c.group(1))
            elif line.startswith("@@"):
                marked.append((self.now, []))
            elif marked:
                marked[-1][1].append(line)
        return marked

    def run_to(self, cycle: int, *before: str, after: tuple[str, ...] = ()) -> list[str]:
        """Run on to instruction cycle ``cycle`` (see :meth:`run_plan`); ``before`` and
        ``after`` are commands sent in the same batch, ``after``'s output is returned."""
        return self.run_plan([(cycle, after)], before)[0][1]

    def step_poll(self, count: int, commands: tuple[str, ...]) -> list[tuple[int, list[str]]]:
        """One batch of ``count`` single instruction steps, ``commands`` after each:
        (cycle after the step, the commands' output) for each step."""
        out = self.command(*(["step", "cycles", "echo @@", *commands] * count))
        polls = self._marked(out)
        if len(polls) != count:
            raise self._fail(f"gpsim did not stop where expected ({len(polls)} of {count} "
                             "steps):\n" + "\n".join(out[-10:]))
        return polls

    def value(self, name: str, out: list[str] | None = None) -> int:
        """A register or symbol as gpsim prints it (``portc`` -> ``_PORTC = 0x18``)."""
        lines = self.command(name) if out is None else out
        want = name.lstrip("_").upper()
        for line in reversed(lines):
            m = _VALUE_RE.match(line)
            if m and m.group(1).upper() == want:
                return int(m.group(2), 0)
        raise ToolchainError(f"gpsim printed no value for {name!r}: {lines[-3:]}")

    def close(self, kill: bool = False) -> None:
        """Quit gpsim (killed at once with ``kill``, or if it does not exit within
        2 s); idempotent."""
        proc, self._proc = self._proc, None
        if proc is None:
            return
        assert proc.stdin is not None and proc.stdout is not None   # started with pipes
        try:
            proc.stdin.write(b"quit\n")
            proc.stdin.close()
        except (BrokenPipeError, OSError, ValueError):
            pass
        try:
            proc.wait(timeout=0.0 if kill else 2.0)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        proc.stdout.close()


# I2C specification UM10204, table 10: minimum times in seconds (hd_dat: the 300 ns
# a device needs to bridge SCL's undefined falling region).
_STANDARD = {"low": 4.7e-6, "high": 4.0e-6, "su_sta": 4.7e-6, "hd_sta": 4.0e-6,
             "su_sto": 4.0e-6, "buf": 4.7e-6, "su_dat": 250e-9, "hd_dat": 300e-9}
_FAST = {"low": 1.3e-6, "high": 0.6e-6, "su_sta": 0.6e-6, "hd_sta": 0.6e-6,
         "su_sto": 0.6e-6, "buf": 1.3e-6, "su_dat": 100e-9, "hd_dat": 300e-9}


@dataclass(frozen=True)
class I2cTiming:
    """Bus times in instruction cycles; a bit is ``low + high`` cycles."""

    low: int
    high: int
    su_sta: int
    hd_sta: int
    su_sto: int
    buf: int
    hd_dat: int

    @property
    def bit(self) -> int:
        return self.low + self.high

    @classmethod
    def for_speed(cls, speed_hz: int, cycles_per_second: int) -> I2cTiming:
        """The fastest timing not above ``speed_hz`` that keeps every minimum time."""
        if not 0 < speed_hz <= 400_000:
            raise ToolchainError(f"I2C speed {speed_hz} Hz: the master does 1 .. 400000")
        spec = _STANDARD if speed_hz <= 100_000 else _FAST
        c = {k: math.ceil(v * cycles_per_second - 1e-9) for k, v in spec.items()}
        period = math.ceil(cycles_per_second / speed_hz - 1e-9)
        high = max(c["high"], period // 2)
        low = max(c["low"], period - high, c["hd_dat"] + c["su_dat"])
        return cls(low=low, high=high, su_sta=c["su_sta"], hd_sta=c["hd_sta"],
                   su_sto=c["su_sto"], buf=c["buf"], hd_dat=c["hd_dat"])


class I2cBusError(ToolchainError):
    """The bus did something a master cannot go on from (a line stuck low)."""


@dataclass
class I2cMaster:
    """A bit-banged I2C master in a :class:`GpsimSession` (SCL/SDA as pin names).

    A clock is: SDA set ``hd_dat`` after SCL fell, SCL released ``low`` after it fell,
    held high ``high`` cycles from the cycle it reads high (a stretching slave holds it
    low: waited for, bounded by ``stretch_limit``, else I2cBusError), SDA sampled, SCL
    pulled low. The end of one clock goes in the same gpsim batch as the start of the
    next, so an unstretched bit costs one batch. ``stretches`` holds (cycle released,
    cycles held low) for every stretched clock, to the instruction (1-2 cycles).
    """

    session: GpsimSession
    timing: I2cTiming
    scl: str = "RC3"
    sda: str = "RC4"
    stretch_limit: int = 50_000          # 10 ms at 5 MIPS (SMBus allows 25 ms)
    stretches: list[tuple[int, int]] = field(default_factory=list)
    _fell: int = 0                       # cycle SCL was last pulled low
    _tail: int | None = None             # SCL high: the cycle it may be pulled low
    _samples: list[int] = field(default_factory=list)   # SDA at each clock's end

    def __post_init__(self) -> None:
        ports = {self._port(p)[0] for p in (self.scl, self.sda)}
        self._reads = tuple(sorted(ports))

    def attach(self) -> I2cMaster:
        """Pull-ups on both lines, released: the bus idles high."""
        for name, pin in (("PSCL", self.scl), ("PSDA", self.sda)):
            node = "n" + name[1:].lower()
            self.session.command(f"module load pullup {name}", f"node {node}",
                                 f"attach {node} {_gpsim_pin(pin)} {name}.pin",
                                 f"{name}.voltage = 5.0")
        return self

    # -- lines ----------------------------------------------------------------------
    @staticmethod
    def _port(pin: str) -> tuple[str, int]:
        m = re.fullmatch(r"R([A-E])([0-7])", pin)
        if not m:
            raise ToolchainError(f"pin {pin!r} is not a port pin")
        return f"port{m.group(1).lower()}", int(m.group(2))

    def levels(self, out: list[str]) -> tuple[int, int]:
        """(SCL, SDA) pin levels from the output of the ``portX`` reads."""
        got = []
        for pin in (self.scl, self.sda):
            port, bit = self._port(pin)
            got.append((self.session.value(port, out) >> bit) & 1)
        return got[0], got[1]

    @staticmethod
    def _set(line: str, level: int) -> str:
        return f"P{line}.voltage = {5.0 if level else 0.0}"

    def _end_clock(self) -> list[tuple[int, tuple[str, ...]]]:
        """The plan step that ends a pending clock (sample SDA, SCL low), if any."""
        return [] if self._tail is None else [(self._tail, (*self._reads, self._set("SCL", 0)))]

    def _ended(self, steps: list[tuple[int, list[str]]]) -> list[tuple[int, list[str]]]:
        """Book the step of :meth:`_end_clock` (first in ``steps``); the rest."""
        if self._tail is None:
            return steps
        self._fell, out = steps[0]
        self._samples.append(self.levels(out)[1])
        self._tail = None
        return steps[1:]

    def _flush(self) -> None:
        """End a pending clock now."""
        if self._tail is not None:
            self._ended(self.session.run_plan(self._end_clock()))

    def _rise(self, sda: int) -> int:
        """(Ending a pending clock,) SDA to ``sda``, SCL released; the cycle SCL reads
        high."""
        t = self.timing
        fell = self._fell if self._tail is None else self._tail + 1
        steps = self._ended(self.session.run_plan(
            [*self._end_clock(), (fell + t.hd_dat, (self._set("SDA", sda),)),
             (fell + t.low, (self._set("SCL", 1), *self._reads))]))
        return self._wait_scl_high(steps[-1][1])

    def _clock(self, sda: int) -> None:
        """Start a clock with SDA at ``sda`` (1 = released); it ends with the next
        operation (:meth:`_flush`), which samples SDA."""
        self._tail = self._rise(sda) + self.timing.high

    def _wait_scl_high(self, out: list[str]) -> int:
        """The cycle SCL reads high (released just before ``out`` was read)."""
        s = self.session
        released = s.now
        if self.levels(out)[0]:
            return released
        batch = max(1, self.timing.high // 2)      # steps past the release count as high
        while s.now - released < self.stretch_limit:
            for cycle, lines in s.step_poll(batch, self._reads):
                if self.levels(lines)[0]:
                    self.stretches.append((released, cycle - released))
                    return cycle
        raise I2cBusError(f"SCL held low for {s.now - released} cycles after the master "
                          f"released it at cycle {released} (limit {self.stretch_limit}): "
                          "a slave stretches the clock without end or the line is stuck low")

    # -- conditions and bytes -------------------------------------------------------
    def start(self) -> None:
        """START on an idle bus (both lines must read high)."""
        s, t = self.session, self.timing
        scl, sda = self.levels(s.command(*self._reads))
        if not (scl and sda):
            raise I2cBusError(f"bus not idle at cycle {s.now} (SCL={scl}, SDA={sda}): "
                              "cannot send START")
        self._fell = s.run_plan([(s.now + t.hd_sta, (self._set("SCL", 0),))],
                                before=(self._set("SDA", 0),))[0][0]

    def repeated_start(self) -> None:
        """Repeated START inside a transfer."""
        s, t = self.session, self.timing
        high_from = self._rise(1)
        steps = s.run_plan([(high_from + t.su_sta, (*self._reads, self._set("SDA", 0))),
                            (high_from + t.su_sta + t.hd_sta, (self._set("SCL", 0),))])
        if not self.levels(steps[0][1])[1]:
            raise I2cBusError(f"SDA held low at cycle {steps[0][0]}: cannot send a "
                              "repeated START")
        self._fell = steps[1][0]

    def stop(self) -> None:
        """STOP, then the bus free time."""
        s, t = self.session, self.timing
        high_from = self._rise(0)
        steps = s.run_plan([(high_from + t.su_sto, (self._set("SDA", 1),)),
                            (high_from + t.su_sto + t.buf, self._reads)])
        scl, sda = self.levels(steps[1][1])
        if not (scl and sda):
            raise I2cBusError(f"bus not released after STOP at cycle {s.now} "
                              f"(SCL={scl}, SDA={sda})")

    def write(self, byte: int) -> bool:
        """Send a byte, MSB first; True if the slave ACKed it."""
        for i in range(7, -1, -1):
            self._clock((byte >> i) & 1)
        self._clock(1)
        self._flush()
        return self._samples[-1] == 0

    def read(self, ack: bool) -> int:
        """Receive a byte (SDA released); ACK it (more to come) or NACK it (the last)."""
        for _ in range(8):
            self._clock(1)
        self._clock(0 if ack else 1)
        self._flush()
        value = 0
        for bit in self._samples[-9:-1]:
            value = value << 1 | bit
        return value

    # -- register maps ----------------------------------------------------------------
    def write_registers(self, address: int, first: int, data: bytes) -> list[bool]:
        """START, address+W, register pointer, data, STOP: the ACK of each byte sent
        (the transfer stops at the first NACK)."""
        self.start()
        acks = [self.write(address << 1)]
        for b in bytes([first]) + bytes(data):
            if not acks[-1]:
                break
            acks.append(self.write(b))
        self.stop()
        return acks

    def read_registers(self, address: int, first: int, count: int) -> bytes:
        """Pointer written, repeated START, ``count`` bytes read (each ACKed but the
        last, NACKed), STOP. A missing ACK is an I2cBusError."""
        self.start()
        for what, b in (("address", address << 1), ("register pointer", first)):
            if not self.write(b):
                self.stop()
                raise I2cBusError(f"no ACK from 0x{address:02X} for the {what}")
        self.repeated_start()
        if not self.write(address << 1 | 1):
            self.stop()
            raise I2cBusError(f"no ACK from 0x{address:02X} for the read address")
        data = bytes(self.read(ack=i < count - 1) for i in range(count))
        self.stop()
        return data
