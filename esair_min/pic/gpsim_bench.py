"""Exact cycle counts of the central board's PIC firmware, measured in gpsim.

- **Decoder**: the superloop's drain loop (``app_main``) takes a byte out of the
  receive ring (``hal_uart_rx``), then handles a byte that does not end a line inline
  (the fast path, ``ES_RX_CHAR``) or calls ``core_rx_end`` for a line end (the slow
  path), and branches back to the loop's head. Execution breakpoints on the first
  instruction of the loop's body (the byte is in hand) and on every branch from the
  body back to the head (addresses from gplink's listing); a stream of command lines
  goes in at line rate through the usart module; each byte is timed from the body's
  first instruction to the end of its branch back (2 cycles), minus any interrupt
  that ran inside. The n-th byte timed is the n-th byte of the stream; a breakpoint
  on ``core_rx_end``'s entry tells which bytes took the slow path.
- **ISR**: breakpoints on the high-priority vector (0x0008) and on the ISR's RETFIE;
  an ISR whose span holds a rising edge of the sync pin is a Timer2 tick.
- **Tick to frame**: from the gpsim harness run (:mod:`esair_min.pic.gpsim_harness`): the
  cycles from the sync pin's rising edge (set in the Timer2 ISR) to the last byte
  (its ACK clock) and to the STOP of the actuator write that follows on that tick.
"""

from __future__ import annotations

import re
import statistics
from dataclasses import dataclass, field
from pathlib import Path

from esair_min.pic.gpsim_harness import GpsimRun, GpsimSetup, _Script, _stimulus_line, setup_lines
from esair_min.pic.gpsim_wave import read_edges
from esair_min.core.stimulus import unescape
from esair_min.core.image import build_image, write_hex
from esair_min.model.robot import Robot
from esair_min.pic.toolchain import Toolchain, ToolchainError, run_gpsim

ISR_VECTOR = 0x0008          # PIC18 high-priority interrupt vector
RETURN_CYCLES = 2            # RETURN / RETFIE
MAX_REPLY = 80               # bytes of the longest reply line (TX interrupts per command)

_LABEL_RE = re.compile(r"^\s+(_\w+):\s*$")
_INSN_RE = re.compile(r"^([0-9a-f]{6})\s+[0-9a-f]{4}\s+(\w+)(?:\s+(0x[0-9a-f]+))?")
_SKIPS = ("bz", "bnz", "bc", "bnc", "bn", "bnn", "bov", "bnov")


@dataclass(frozen=True)
class FunctionSpan:
    entry: int
    exits: tuple[int, ...]    # addresses of its RETURN / RETFIE instructions


Insn = tuple[int, str, "int | None"]   # address, mnemonic, first operand if an address


def _listing_functions(lst_text: str) -> dict[str, list[Insn]]:
    """The instructions of every C function (``_name``) in a gplink listing, in order.

    A function is a pCode block; the block's first label names it."""
    out: dict[str, list[Insn]] = {}
    current: list[Insn] | None = None
    expect_name = False
    for line in lst_text.splitlines():
        if "Starting pCode block" in line:
            current, expect_name = None, True
            continue
        m = _LABEL_RE.match(line)
        if m:
            if expect_name:
                current = out.setdefault(m.group(1), [])
                expect_name = False
            continue
        i = _INSN_RE.match(line)
        if i and current is not None:
            current.append((int(i.group(1), 16), i.group(2).lower(),
                            int(i.group(3), 16) if i.group(3) else None))
    return out


def function_spans(lst_text: str) -> dict[str, FunctionSpan]:
    """Entry and exit addresses of every C function in a gplink listing (``_name``)."""
    return {name: FunctionSpan(insns[0][0],
                               tuple(a for a, op, _ in insns if op in ("return", "retfie")))
            for name, insns in _listing_functions(lst_text).items() if insns}


@dataclass(frozen=True)
class DrainLoop:
    """The superloop's receive loop in ``app_main``: ``while (ready && hal_uart_rx(&b))
    { body }``."""
    body: int                 # first instruction of the body: the byte is in hand
    ends: tuple[int, ...]     # the body's branches back to the loop's head
    head: int


def _instructions(lst_text: str, function: str) -> list[Insn]:
    """(address, mnemonic, first operand if an address) of every instruction of a C
    function (``_name``) in a gplink listing."""
    return _listing_functions(lst_text).get(function, [])


def drain_loop(lst_text: str) -> DrainLoop:
    """Find the drain loop in ``app_main``: the conditional branch after the call of
    ``hal_uart_rx`` leaves the loop (its target is the exit), the instruction after it
    starts the body, and every ``bra``/``goto`` in the body back before the body goes to
    the head."""
    spans = function_spans(lst_text)
    if "_hal_uart_rx" not in spans:
        raise ToolchainError("listing: no function _hal_uart_rx")
    insns = _instructions(lst_text, "_app_main")
    rx = spans["_hal_uart_rx"].entry
    calls = [k for k, (_, op, arg) in enumerate(insns) if op == "call" and arg == rx]
    if not calls:
        raise ToolchainError("listing: _app_main does not call _hal_uart_rx")
    k = next((j for j in range(calls[0] + 1, len(insns)) if insns[j][1] in _SKIPS), None)
    if k is None or k + 1 >= len(insns) or (exit_at := insns[k][2]) is None:
        raise ToolchainError("listing: no loop exit after the call of _hal_uart_rx")
    body = insns[k + 1][0]
    back = [(a, t) for a, op, t in insns
            if op in ("bra", "goto") and t is not None and body <= a < exit_at and t < body]
    heads = {t for _, t in back}
    if not back or len(heads) != 1:
        raise ToolchainError(f"listing: the drain loop's body at {body:#x} has "
                             f"{len(heads)} branch targets back (expected one head)")
    return DrainLoop(body, tuple(a for a, _ in back), heads.pop())


@dataclass(frozen=True)
class Hit:
    cycle: int
    addr: int


_HIT_RE = re.compile(r"Execution at \S+\((0x[0-9a-fA-F]+)\)|(?:^|> )(\d+) = 0x[0-9A-Fa-f]+\s*$",
                     re.M)


def parse_hits(output: str) -> list[Hit]:
    """Breakpoint hits from a script of ``run`` + ``cycles`` pairs: each ``Execution at``
    line is paired with the ``cycles`` printed right after it."""
    hits: list[Hit] = []
    pending: int | None = None
    for m in _HIT_RE.finditer(output):
        if m.group(1):
            pending = int(m.group(1), 16)
        elif pending is not None:
            hits.append(Hit(int(m.group(2)), pending))
            pending = None
    return hits


@dataclass(frozen=True)
class Interval:
    start: int
    end: int                  # cycle after the last instruction


def _pair(hits: list[Hit], entry: int, exits: set[int]) -> list[Interval]:
    out, start = [], None
    for h in hits:
        if h.addr == entry and start is None:
            start = h.cycle
        elif h.addr in exits and start is not None:
            out.append(Interval(start, h.cycle + RETURN_CYCLES))
            start = None
    return out


@dataclass(frozen=True)
class DecoderFigures:
    chars: list[int]          # cycles of each byte that does not end a line (CR, LF),
                              # no interrupt inside (see interrupted_chars)
    slow_chars: int           # how many of those took the slow path (none: CR and LF only)
    line_ends: list[tuple[str, int]]   # (the line, cycles of its terminator byte)
    slow_ends: int            # how many line ends went to core_rx_end (the slow path)
    isr: list[int]            # cycles of every ISR run
    isr_tick: list[int]       # cycles of the ISR runs that handled a Timer2 tick
    total_bytes: int
    # such bytes left out of chars: an interrupt ran inside, and its span from the
    # vector to RETFIE misses its entry and return (a cycle or two more than the byte)
    interrupted_chars: int = 0

    @property
    def all_bytes(self) -> list[int]:
        return self.chars + [c for _, c in self.line_ends]


def rx_stream(stimulus: str) -> bytes:
    """The bytes of every ``rx`` line of a stimulus script, in order."""
    out = bytearray()
    for raw in stimulus.splitlines():
        line = raw.lstrip()
        if line == "rx" or line.startswith("rx "):
            out += unescape(line[3:])
    return bytes(out)


def bench_script(robot: Robot, stimulus: str, cod: str, breaks: list[str]) -> tuple[str, int]:
    """A gpsim command file that plays ``stimulus`` with execution breakpoints set.

    With breakpoints, ``run`` stops at every hit, so each ``tick N`` after a command
    becomes ``break c T`` and enough ``run`` + ``cycles`` pairs for every hit expected
    before T (decoder calls and RX interrupts per byte, TX interrupts per reply byte,
    a tick interrupt per tick). Extra pairs only delay the next command (at most one
    tick each: the tick interrupt always stops the run). Returns the script and the
    planned end cycle."""
    sc = _Script(GpsimSetup.from_robot(robot))
    s = sc.setup
    sc.lines += setup_lines(s, cod, "image.hex")
    line_bytes = 0
    for raw in stimulus.splitlines():
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        words = line.split()
        if words[0] == "rx":
            data = unescape(raw.lstrip()[3:])
            sc.lines += [f"U1.tx = {b:#04x}" for b in data]
            line_bytes += len(data)
        elif words[0] == "tick":
            n = int(words[1]) if len(words) > 1 else 1
            sc.now += n * s.tick_cycles
            hits = 2 * (2 * line_bytes + MAX_REPLY + 2 * n) + 10
            sc.lines += [f"break c {sc.now}"] + ["run", "cycles"] * hits
            line_bytes = 0
        else:
            _stimulus_line(sc, line)
            if line == "boot":
                sc.lines += breaks
    sc.lines += ["log off", 'FSCL.file = "/dev/null"', 'FSDA.file = "/dev/null"',
                 'FSYNC.file = "/dev/null"', "cycles", "quit"]
    return "\n".join(sc.lines) + "\n", sc.now


def measure_decoder(robot: Robot, stimulus: str, cod: Path, lst: Path, workdir: Path,
                    tc: Toolchain | None = None) -> DecoderFigures:
    """Play ``stimulus`` (a stimulus script) on the central firmware; time the drain
    loop's work on every received byte and every interrupt."""
    text = Path(lst).read_text(errors="replace")
    spans = function_spans(text)
    for need in ("_core_rx_end", "_isr"):
        if need not in spans or not spans[need].exits:
            raise ToolchainError(f"{lst}: no function {need} with a return in the listing")
    loop, dec, isr = drain_loop(text), spans["_core_rx_end"], spans["_isr"]
    workdir.mkdir(parents=True, exist_ok=True)
    write_hex(build_image(robot), workdir / "image.hex")
    breaks = [f"break e {loop.body:#x}"] + [f"break e {a:#x}" for a in loop.ends] + \
        [f"break e {dec.entry:#x}", f"break e {ISR_VECTOR:#x}"] + \
        [f"break e {a:#x}" for a in isr.exits]
    script, _end = bench_script(robot, stimulus, str(Path(cod).resolve()), breaks)
    out = run_gpsim(script, workdir, timeout=300, tc=tc, script_name="bench.stc")
    hits = parse_hits(out)
    calls = _pair(hits, loop.body, set(loop.ends))
    slow = [any(c.start <= h.cycle < c.end for h in hits if h.addr == dec.entry)
            for c in calls]
    isrs = _pair(hits, ISR_VECTOR, set(isr.exits))
    stream = rx_stream(stimulus)
    if len(calls) != len(stream):
        raise ToolchainError(f"{len(calls)} received bytes timed for {len(stream)} bytes "
                             "sent (bytes lost, or too few gpsim stops)")
    sync_up = [c for c, v in read_edges(workdir / "sync.txt") if v == 1 and c > 0]
    tick_isrs = [i for i in isrs if any(i.start <= c <= i.end for c in sync_up)]

    def inside(call: Interval) -> list[Interval]:
        return [i for i in isrs if call.start <= i.start and i.end <= call.end]

    chars, ends, line, slow_chars, slow_ends, interrupted = [], [], bytearray(), 0, 0, 0
    for b, call, took_slow in zip(stream, calls, slow):
        inner = inside(call)
        cycles = call.end - call.start - sum(i.end - i.start for i in inner)
        if b in (0x0A, 0x0D):
            ends.append((line.decode("latin-1") + ("\\r" if b == 0x0D else "\\n"), cycles))
            line.clear()
            slow_ends += took_slow
        else:
            line.append(b)
            if inner:
                interrupted += 1
            else:
                chars.append(cycles)
            slow_chars += took_slow
    return DecoderFigures(chars=chars, slow_chars=slow_chars, line_ends=ends,
                          slow_ends=slow_ends,
                          isr=[i.end - i.start for i in isrs],
                          isr_tick=[i.end - i.start for i in tick_isrs],
                          total_bytes=len(stream), interrupted_chars=interrupted)


@dataclass(frozen=True)
class FrameTiming:
    to_last_byte: list[int]   # sync rising edge -> 9th clock of the last byte, cycles
    to_stop: list[int]        # sync rising edge -> STOP
    write: list[int]          # START -> STOP of each full-frame write
    read: list[int]           # START -> STOP of each frame read from the EEPROM
    # to_last_byte of the writes that come one tick after the previous one: frames of
    # a motion played a frame per tick (the others wait for a command's own work)
    played: list[int] = field(default_factory=list)


def frame_timing(run: GpsimRun, actuator: int, eeprom: int, frame_bytes: int,
                 tick_cycles: int = 0) -> FrameTiming:
    """Each full-frame write to the actuator (register byte + ``frame_bytes``): cycles
    since the latest rising edge of the sync pin, and the bus time of each write and of
    each frame-sized EEPROM read. When a tick's work overruns the next tick, the sync
    pin stays high and the delay spans several ticks. With ``tick_cycles``, the writes
    within a quarter tick of one tick after the previous write are also in ``played``."""
    ups = [c for c, v in run.sync_edges if v == 1 and c > 0]
    last, stops, writes, reads, played = [], [], [], [], []
    prev = None
    for t in run.transfers:
        if not t.segments or t.stop is None:
            continue
        first, final = t.segments[0], t.segments[-1]
        if final.reading and final.address == eeprom and len(final.data) == frame_bytes:
            reads.append(t.stop - t.start)
        if first.address != actuator or first.reading or len(first.data) != frame_bytes + 1:
            continue
        writes.append(t.stop - t.start)
        edge = max((c for c in ups if c <= t.start), default=None)
        if edge is not None:
            last.append(t.last_byte_end - edge)
            stops.append(t.stop - edge)
            if (tick_cycles and prev is not None
                    and abs(t.start - prev - tick_cycles) < tick_cycles // 4):
                played.append(t.last_byte_end - edge)
        prev = t.start
    return FrameTiming(last, stops, writes, reads, played)


def describe(values: list[int]) -> str:
    if not values:
        return "none"
    return f"worst {max(values)}, mean {statistics.fmean(values):.1f}, n {len(values)}"


@dataclass(frozen=True)
class FrameSlips:
    # per actuator write after the first: (gpsim, Python) ticks since the previous one
    gaps: list[tuple[int, int]]
    slipped: int                  # ticks gpsim lost where the Python core writes on consecutive ticks
    worst_late: int               # most ticks a write of such a run came after its tick


def frame_slips(run: GpsimRun, python_trace: list[str], actuator: int,
                tick_cycles: int) -> FrameSlips:
    """Ticks between consecutive actuator writes, in gpsim and in the Python core.

    gpsim's tick of a write is counted from Timer2's period (``(start - first sync
    rising edge) // tick``: when a tick's work overruns, the sync pin stays high and
    rising edges go missing); the Python core's is the last ``T n`` before its ``W``
    line. Writes are matched in order (``compare`` checks that they are equal). Only
    the runs where the Python core writes a frame every tick (a dance with
    ``delay_ticks: 1``) count: there each extra tick in gpsim is a slipped tick, and a
    write is late by the ticks slipped since its run began."""
    prefix = f"W {actuator:02X} "
    py_ticks, tick = [], 0
    for line in python_trace:
        if line.startswith("T "):
            tick = int(line.split()[1])
        elif line.startswith(prefix):
            py_ticks.append(tick)
    ups = [c for c, v in run.sync_edges if v == 1 and c > 0]
    if not ups:
        return FrameSlips([], 0, 0)
    g_ticks = [(t.start - ups[0]) // tick_cycles for t in run.transfers
               if t.segments and t.segments[0].address == actuator
               and not t.segments[0].reading]
    pairs = list(zip(g_ticks, py_ticks))
    gaps = [(g1 - g0, p1 - p0) for (g0, p0), (g1, p1) in zip(pairs, pairs[1:])]
    slipped = late = worst = 0
    for g, p in gaps:
        if p != 1:
            late = 0
            continue
        slipped += max(0, g - 1)
        late = max(0, late + g - 1)
        worst = max(worst, late)
    return FrameSlips(gaps, slipped, worst)
