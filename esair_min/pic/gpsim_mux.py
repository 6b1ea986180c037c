"""An analog multiplexer (74HC4051 class) beside the PIC18F452 in gpsim: the sensor
board's ``mux:`` (docs/board-format.md), modelled as the simavr driver models it for the
ATmega328P (esair_min/avr/simdrv.c, ``mux``).

gpsim has no such part, so the model runs in Python beside the session: gpsim stops on
every write to the select pins' latches (``break w latc``) and to ADCON0; a new select
value shows on the common output (a ``pullup`` module on the mux's ADC channel) when the
mux has settled, ``settle_cycles`` later (a cycle break then), and a conversion started
(ADCON0's GO set) while the output still shows the previous input is counted in
:attr:`GpsimMux.early` and reads that input, as on the part. Exact and deterministic:
every stop is on an instruction boundary of the simulated PIC.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from esair_min.model.hardware import ADC_PINS
from esair_min.pic.gpsim_harness import _gpsim_pin
from esair_min.pic.gpsim_i2c import GpsimSession
from esair_min.pic.toolchain import ToolchainError

_WROTE_RE = re.compile(r"Wrote: 0x([0-9a-fA-F]+) to _(LAT[A-E]|ADCON0)\(")
_CYCLES_RE = re.compile(r"^(\d+) = 0x[0-9A-Fa-f]+\s*$")
B_GO = 0x04                              # ADCON0's GO/DONE
#: The most stops one run_to() may take (a runaway firmware writing its latches in a
#: loop ends the run with an error instead of going on forever).
MAX_STOPS = 100_000


@dataclass
class GpsimMux:
    """The mux of a board: ``select`` pins (S0 first, e.g. ``("RC0", "RC1", "RC2")``) on
    the PIC's latches, its common output on ADC ``channel``, settled ``settle_cycles``
    instruction cycles after a select change. ``inputs``: each input's voltage."""

    session: GpsimSession
    select: tuple[str, ...]
    channel: int
    settle_cycles: int
    inputs: list[float] = field(default_factory=list)
    shown: int = 0                       # the input the common output shows
    early: list[tuple[int, int]] = field(default_factory=list)   # (cycle, input shown)
    stops: int = 0
    _latches: dict[str, int] = field(default_factory=dict)
    _due: dict[int, int] = field(default_factory=dict)      # cycle -> the input shown then
    _pending: int | None = None          # the selected input not yet shown
    _adcon0: int = 0

    def __post_init__(self) -> None:
        if not self.inputs:
            self.inputs = [0.0] * (1 << len(self.select))

    @classmethod
    def for_board(cls, session: GpsimSession, board, inputs: list[float] | None = None,
                  settle_cycles: int | None = None) -> GpsimMux:
        """The mux of ``board`` (a sensor board with ``mux:``); ``settle_cycles`` overrides
        the board file's ``settle_us`` (to model a slower part)."""
        mux = board.mux
        if mux is None:
            raise ToolchainError(f"board '{board.board}' has no mux")
        if settle_cycles is None:
            settle_cycles = -(-mux.settle_us * board.mcu.clock_hz // 4 // 1_000_000)
        return cls(session, tuple(mux.select), mux.channel, settle_cycles,
                   list(inputs) if inputs else [])

    def attach(self) -> GpsimMux:
        """The common output on the ADC pin, the write breaks, the first input shown."""
        pin = _gpsim_pin(ADC_PINS[self.channel])
        ports = sorted({p[1] for p in self.select})
        self.session.command("module load pullup MUXOUT", "node nmuxout",
                             f"attach nmuxout {pin} MUXOUT.pin",
                             f"MUXOUT.voltage = {self.inputs[self.shown]}",
                             *(f"break w lat{p.lower()}" for p in ports), "break w adcon0")
        for p in ports:
            self._latches[p] = self.session.value(f"lat{p.lower()}")
        self._adcon0 = self.session.value("adcon0")
        return self

    def set_inputs(self, inputs: list[float]) -> None:
        """New voltages on the inputs (the output follows at once for the one shown)."""
        if len(inputs) != len(self.inputs):
            raise ValueError(f"expected {len(self.inputs)} input voltages, got {len(inputs)}")
        self.inputs = list(inputs)
        self.session.command(f"MUXOUT.voltage = {self.inputs[self.shown]}")

    def selected(self) -> int:
        """The input the select pins name now (S0 the lowest bit)."""
        value = 0
        for bit, pin in enumerate(self.select):
            if self._latches[pin[1]] >> int(pin[2]) & 1:
                value |= 1 << bit
        return value

    def run_to(self, cycle: int) -> None:
        """Run the PIC to instruction cycle ``cycle`` (or one past it), the mux working."""
        s = self.session
        if cycle <= s.now:
            return
        s.command(f"break c {cycle}")
        for _ in range(MAX_STOPS):
            out = s.command("run", "cycles")
            self.stops += 1
            now = next((int(m.group(1)) for line in out if (m := _CYCLES_RE.match(line))), None)
            if now is None:
                raise ToolchainError(f"gpsim printed no cycle count: {out[-5:]}")
            s.now = now
            self.observe(out, now)
            if now >= cycle:
                return
        raise ToolchainError(f"the mux model stopped {MAX_STOPS} times before cycle {cycle}")

    def observe(self, out: list[str], now: int) -> None:
        """The writes gpsim reported in ``out`` (the PIC stopped at ``now``), and each
        select change that has settled by then shown."""
        for line in out:
            if (m := _WROTE_RE.search(line)):
                self._wrote(m.group(2), int(m.group(1), 16), now)
        for due in sorted(d for d in self._due if d <= now):
            self._show(self._due.pop(due))

    def _wrote(self, register: str, value: int, now: int) -> None:
        if register == "ADCON0":
            started = value & B_GO and not self._adcon0 & B_GO
            self._adcon0 = value
            if started and value >> 3 & 7 == self.channel and self._pending is not None:
                self.early.append((now, self.shown))
            return
        self._latches[register[3]] = value
        want = self.selected()
        if want == self.shown:
            self._pending = None         # back before it settled: it shows that input
            return
        if want == self._pending:
            return
        self._pending = want
        due = now + self.settle_cycles
        self._due[due] = want
        self.session.command(f"break c {due}")

    def _show(self, value: int) -> None:
        if value != self._pending:
            return                       # a later select change overtook this one
        self.shown, self._pending = value, None
        self.session.command(f"MUXOUT.voltage = {self.inputs[value]}")


class MuxSession(GpsimSession):
    """A :class:`GpsimSession` with the board's mux beside the PIC (:meth:`attach_mux`):
    every run (``run_plan``, ``step_poll``, so an :class:`~esair_min.pic.gpsim_i2c.I2cMaster`
    too) goes through the model, stop by stop, one gpsim batch per stop."""

    mux: GpsimMux | None = None

    def attach_mux(self, board, inputs: list[float] | None = None,
                   settle_cycles: int | None = None) -> GpsimMux:
        self.mux = GpsimMux.for_board(self, board, inputs, settle_cycles).attach()
        return self.mux

    def run_plan(self, plan: list[tuple[int, tuple[str, ...]]],
                 before: tuple[str, ...] = ()) -> list[tuple[int, list[str]]]:
        """As :meth:`GpsimSession.run_plan` (a step less than 2 cycles after the one
        before runs nothing), each run through the mux model."""
        mux = self.mux
        if mux is None:
            return super().run_plan(plan, before)
        if before:
            self.command(*before)
        steps: list[tuple[int, list[str]]] = []
        last, ran = self.now, False
        for cycle, commands in plan:
            if cycle >= last + (2 if ran else 1):
                mux.run_to(cycle)
                ran, last = True, cycle
            steps.append((self.now, self.command(*commands) if commands else []))
        return steps

    def step_poll(self, count: int, commands: tuple[str, ...]) -> list[tuple[int, list[str]]]:
        """As :meth:`GpsimSession.step_poll`, the mux seeing each step's writes."""
        mux = self.mux
        if mux is None:
            return super().step_poll(count, commands)
        polls: list[tuple[int, list[str]]] = []
        for _ in range(count):
            out = self.command("step", "cycles", "echo @@", *commands)
            marked = self._marked(out)
            if len(marked) != 1:
                raise ToolchainError(f"gpsim did not step: {out[-5:]}")
            mux.observe(out, self.now)
            polls.append(marked[0])
        return polls
