"""What the simulator harnesses of PAPA-MAN's central board share (the PIC18F452 in gpsim,
esair_min/pic/gpsim_harness.py; the ATmega328P in simavr, esair_min/avr/simavr_harness.py): the
stimulus script's simulated time (:class:`SimScript`), the verbs whose meaning is the
same in both (``rx``, ``boot``, ``tick``), the line loop that reads a script as the Python
harness and the host C port read it, and where the ``boot`` wait ends
(:func:`boot_wait_end`). Each harness adds its own verbs and turns them into its
simulator's commands.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

from esair_min.core.stimulus import TICKS_MAX
from esair_min.core.script import BLANK, decimal, line_text, script_lines, unescape, words
from esair_min.errors import ProtocolError


class SimScript:
    """A simulator's command lines while keeping the simulated time (cycles). ``setup``
    has ``boot_cycles``, ``tick_cycles``, ``sensor_registers`` and ``balances``."""

    #: the messages of a second ``boot`` and of readings that tip a reaction before it
    SECOND_BOOT = "a second boot is not supported"
    TIPPING = "the readings set before boot tip a balance reaction; set them after boot"

    def __init__(self, setup: Any, boot_end: int | None = None):
        self.setup = setup
        self.lines: list[str] = []
        self.now = 0                 # cycle the simulation stops at after the last run
        self.booted = False
        self.boot_end = setup.boot_cycles if boot_end is None else boot_end
        self.readings = [0] * (setup.sensor_registers // 2)

    def run_lines(self, cycle: int) -> list[str]:
        """The simulator's commands running it to ``cycle``."""
        raise NotImplementedError

    def send(self, data: bytes) -> None:
        """The PC end of the serial link sends ``data``."""
        raise NotImplementedError

    def run_to(self, cycle: int) -> None:
        self.now = max(self.now, cycle)
        self.lines += self.run_lines(self.now)

    def tipping(self) -> bool:
        """Whether the readings set now tip a balance reaction."""
        r = self.readings
        return any(abs(sum(r[i] for i in a) - sum(r[i] for i in b)) > t
                   for a, b, t in self.setup.balances)


def rx(sc: SimScript, text: str) -> None:
    """``rx TEXT``: the PC end of the serial link sends the bytes."""
    if not sc.booted:
        raise ProtocolError("rx before boot")
    sc.send(unescape(text))


def boot(sc: SimScript, args: list[str]) -> bool:
    """``boot``: run to the end of the boot wait (once)."""
    if args:
        return False
    if sc.booted:
        raise ProtocolError(sc.SECOND_BOOT)
    if sc.tipping():
        raise ProtocolError(sc.TIPPING)
    sc.booted = True
    sc.run_to(sc.boot_end)
    return True


def tick(sc: SimScript, args: list[str]) -> bool:
    """``tick [N]``: run N tick periods."""
    if len(args) > 1:
        return False
    n = decimal(args[0], "tick count", TICKS_MAX) if args else 1
    sc.run_to(sc.now + n * sc.setup.tick_cycles)
    return True


Verb = Callable[[Any, list[str]], bool]


def dispatch(sc: SimScript, line: str, verbs: dict[str, Verb]) -> str | None:
    """Run one stimulus line (docs/trace-format.md): ``rx`` keeps its spaces; every other
    line is a verb and its words, each verb a function of ``verbs`` (False: the words do
    not fit it). None when done, else the line's first word (the harness says why not)."""
    if line == "rx" or line.startswith("rx "):
        rx(sc, line[3:])
        return None
    cmd, *args = words(line.split("#", 1)[0])
    verb = verbs.get(cmd)
    if verb is not None and verb(sc, args):
        return None
    return cmd


def feed(sc: SimScript, stimulus: str, one_line: Callable[[Any, str], None],
         after_boot: Iterable[str] = ()) -> None:
    """Every line of ``stimulus`` through ``one_line``, read as the Python harness and the
    host C port read it; an error names its line. ``after_boot``: commands put right
    after the ``boot`` wait."""
    for number, raw in script_lines(stimulus.encode("utf-8")):
        try:
            text = line_text(raw)
            stripped = text.strip(BLANK)
            if not stripped or stripped.startswith("#"):
                continue
            one_line(sc, stripped if not stripped.startswith("rx") else text.lstrip(BLANK))
        except ProtocolError as exc:
            raise ProtocolError(f"stimulus line {number}: {exc.message}") from None
        if stripped == "boot":
            sc.lines += after_boot


def boot_wait_end(rises: list[int], boot_cycles: int, tick_cycles: int, poll_period: int,
                  lead: float) -> int:
    """The cycle the ``boot`` wait ends at, from the sync pin's rising edges of a run of
    the boot alone (tick 1 is the first; the timer is exactly periodic): a whole number
    of ``poll_period`` ticks served by ``boot_cycles``, then ``lead`` of a tick."""
    done = (boot_cycles - rises[0]) // tick_cycles + 1          # ticks by boot_cycles
    n = done + -done % poll_period
    return rises[0] + (n - 1) * tick_cycles + int(lead * tick_cycles)


def split_replies(tx: Iterable[tuple[int, int]]) -> list[tuple[int, bytes]]:
    """The bytes the firmware sent, ``(cycle, byte)``, as ``(cycle of its LF, line)``."""
    out = []
    line = bytearray()
    for cycle, b in tx:
        line.append(b)
        if b == 0x0A:
            out.append((cycle, bytes(line)))
            line.clear()
    return out


def trace_lines(sync_edges: Iterable[tuple[int, int]], replies: Iterable[tuple[int, bytes]],
                transfers: Iterable[Any]) -> list[str]:
    """A run as docs/trace-format.md lines, ordered by cycle: ``T n`` at the sync pin's
    rising edges from reset, ``TX`` per reply, each I2C transfer's trace line (a transfer
    cut before its address byte has no segments and is left out)."""
    events: list[tuple[int, int, str]] = []
    ticks = [c for c, v in sync_edges if v == 1 and c > 0]
    for n, c in enumerate(ticks, start=1):
        events.append((c, 0, f"T {n}"))
    for c, line in replies:
        events.append((c, 1, f"TX {line.hex().upper()}"))
    for t in transfers:
        if t.segments:
            events.append((t.start, 2, t.trace_line()))
    events.sort()
    return ["# esair-trace 1"] + [text for _, _, text in events]
