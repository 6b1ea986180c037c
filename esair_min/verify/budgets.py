"""Timing and memory budgets from the chip simulators, each against the board file's
own settings, with a verdict and, over budget, what to change.

- decoder: the worst cycles the superloop spends on one received byte that does not
  end a line, plus the worst interrupt (one may come with every byte), against the
  cycles one byte takes at the configured baud;
- worst ISR against one byte time (the USART holds the next byte meanwhile);
- tick: from each tick with a frame write (the sync pin's rising edge) to the end of
  the last I2C transfer started in that tick (the frame write, the read of the next
  frame, a sensor poll) against the tick, at the configured I2C speed; and no played
  frame may slip a tick;
- stack: the deepest the central board's stack went in the run against the RAM left
  for it (PIC: SDCC's software stack section; AVR: RAM above .data and .bss);
- flash and RAM of every board against its chip.

PIC figures are instruction cycles (4 clocks), AVR figures CPU cycles.
"""

from __future__ import annotations

import re
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from esair_min.model.robot import Robot
from esair_min.verify.default_scenario import settle_ticks
from esair_min.verify.targets import Firmware, TargetRun

FILL = 0xA5                 # the PIC stack area's watermark byte
FILL_TOP_MARGIN = 8         # bytes under the stack's top left unfilled (main's entry frame)


@dataclass
class Budget:
    target: str
    name: str
    used: int
    allowed: int
    unit: str
    detail: str = ""
    change: str = ""          # what to change when over

    @property
    def ok(self) -> bool:
        return self.used <= self.allowed

    @property
    def share(self) -> float:
        return self.used / self.allowed if self.allowed else float(self.used > 0)

    def as_dict(self) -> dict[str, Any]:
        return {**asdict(self), "ok": self.ok}


# -- PIC: the stack watermark -------------------------------------------------------------

def pic_stack_commands(lst: Path) -> tuple[tuple[str, ...], tuple[str, ...], range]:
    """gpsim commands: stop at ``main``'s entry (after the start-up code cleared RAM) and
    fill the stack area under its top with :data:`FILL`; print the area at the end."""
    from esair_min.codegen.context import PIC_STACK
    from esair_min.pic.gpsim_bench import function_spans

    spans = function_spans(lst.read_text(errors="replace"))
    bottom, size = PIC_STACK["bottom"], PIC_STACK["size"]
    area = range(bottom, bottom + size - FILL_TOP_MARGIN)
    prologue = (f"break e {spans['_main'].entry:#x}", "run",
                *(f"reg({a:#x}) = {FILL:#04x}" for a in area))
    epilogue = tuple(f"reg({a:#x})" for a in area)
    return prologue, epilogue, area


_REG_RE = re.compile(r"\[FIXME-ui\.cc\(\$([0-9a-fA-F]+)\)\] = \$([0-9a-fA-F]{2})")


def pic_stack_bytes(output: str, area: range, size: int) -> int:
    """The deepest the stack went: from the top of the area to the lowest byte no longer
    :data:`FILL` (the printed values are the last ``len(area)`` register reads)."""
    values = [int(v, 16) for _, v in _REG_RE.findall(output)][-len(area):]
    if len(values) != len(area):
        return size          # unreadable: count the whole stack as used
    touched = [a for a, v in zip(area, values) if v != FILL]
    return area.start + size - min(touched) if touched else FILL_TOP_MARGIN


# -- the decoder --------------------------------------------------------------------------

def decoder_stimulus(robot: Robot) -> str:
    """A short script for the decoder bench (its own run on either chip, with
    breakpoints or watched addresses): a few commands and a long bad line."""
    lines = ["boot", "tick 4"]
    for cmd in robot.commands[:6]:
        if cmd.action in ("version", "stop", "sensors", "speeds"):
            text = cmd.prefix + ("003" * len(robot.servos) if cmd.action == "speeds" else "")
            lines += [f"rx {text}\\r", f"tick {settle_ticks(robot, len(text) + 1)}"]
    lines += ["rx " + "0123456789" * 4 + "0123\\r", f"tick {settle_ticks(robot, 45)}"]
    return "\n".join(lines) + "\n"


def pic_decoder(robot: Robot, stimulus: str, cod: Path, lst: Path,
                workdir: Path) -> tuple[list[int], list[int], int]:
    """The PIC's decoder bench (esair_min.pic.gpsim_bench's breakpoints on the drain loop,
    ``core_rx_end`` and the ISR): the cycles of each received byte that took no slow path
    and had no interrupt inside, every ISR's cycles, and how many bytes sent were never
    taken (lost: the decoder did not keep up), where ``measure_decoder`` gives up."""
    from esair_min.core.image import build_image, write_hex
    from esair_min.pic.gpsim_bench import (ISR_VECTOR, RETURN_CYCLES, bench_script, drain_loop,
                                           function_spans, parse_hits, rx_stream)
    from esair_min.pic.toolchain import ToolchainError, run_gpsim

    text = lst.read_text(errors="replace")
    spans = function_spans(text)
    for need in ("_core_rx_end", "_isr"):
        if need not in spans or not spans[need].exits:
            raise ToolchainError(f"{lst}: no function {need} with a return in the listing")
    loop, dec, isr = drain_loop(text), spans["_core_rx_end"], spans["_isr"]
    workdir.mkdir(parents=True, exist_ok=True)
    write_hex(build_image(robot), workdir / "image.hex")
    breaks = ([f"break e {loop.body:#x}"] + [f"break e {a:#x}" for a in loop.ends]
              + [f"break e {dec.entry:#x}", f"break e {ISR_VECTOR:#x}"]
              + [f"break e {a:#x}" for a in isr.exits])
    script, _ = bench_script(robot, stimulus, str(cod.resolve()), breaks)
    hits = parse_hits(run_gpsim(script, workdir, timeout=300, script_name="bench.stc"))

    def pair(entry: int, exits: set[int]) -> list[tuple[int, int]]:
        out, start = [], None
        for h in hits:
            if h.addr == entry and start is None:
                start = h.cycle
            elif h.addr in exits and start is not None:
                out.append((start, h.cycle + RETURN_CYCLES))
                start = None
        return out

    calls, isrs = pair(loop.body, set(loop.ends)), pair(ISR_VECTOR, set(isr.exits))
    slow = {h.cycle for h in hits if h.addr == dec.entry}
    chars = [e - s for s, e in calls
             if not any(s <= c < e for c in slow) and not any(s <= a and b <= e for a, b in isrs)]
    return chars, [e - s for s, e in isrs], max(0, len(rx_stream(stimulus)) - len(calls))


def avr_decoder(run: Any, rx_addr: int) -> list[int]:
    """Cycles of each received byte that does not end a line: from an entry of
    ``hal_uart_rx`` to the next, with no other watched function entered between (the
    pass's first call, ``hal_watchdog_clear``, or a line end's ``core_rx_end``), less
    the interrupts inside."""
    spans: list[tuple[int, int]] = []
    entry = None
    for cycle, v in run.isrs.get(0, []):
        if v and entry is None:
            entry = cycle
        elif not v and entry is not None:
            spans.append((entry, cycle))
            entry = None
    out: list[int] = []
    prev = None
    for cycle, addr in run.hits:
        if addr != rx_addr:
            prev = None
            continue
        if prev is not None:
            out.append(cycle - prev - sum(e - s for s, e in spans if prev <= s and e <= cycle))
        prev = cycle
    return out


# -- the tick -------------------------------------------------------------------------------

def tick_work(run: Any, actuator: int, frame_bytes: int, tick: int) -> tuple[list[int], list[int]]:
    """For each full-frame write: its cycles from START to STOP, and from the latest sync
    rising edge to the end of the last transfer started within that tick period (the
    write, the read of the next frame, a sensor poll)."""
    ups = [c for c, v in run.sync_edges if v == 1 and c > 0]
    writes, whole = [], []
    for t in run.transfers:
        first = t.segments[0] if t.segments else None
        if (first is None or first.address != actuator or first.reading
                or len(first.data) != frame_bytes + 1 or t.stop is None):
            continue
        writes.append(t.stop - t.start)
        edge = max((c for c in ups if c <= t.start), default=None)
        if edge is not None:
            whole.append(max([t.stop] + [u.stop for u in run.transfers
                                         if u.stop is not None and edge <= u.start < edge + tick])
                         - edge)
    return writes, whole


def _without_probes(sim: Any) -> Any:
    """The run's sync edges and its transfers but the probes (an address acknowledged with
    no data: an I2C scan, ACK polling), which the Python core's trace lists as ``P``."""
    from types import SimpleNamespace

    return SimpleNamespace(sync_edges=sim.sync_edges, transfers=[
        t for t in sim.transfers
        if not (t.segments and not t.segments[0].data and t.segments[0].addr_ack)])


# -- all of them ----------------------------------------------------------------------------

def chip_budgets(robot: Robot, fw: Firmware, run: TargetRun, py: TargetRun,
                 decoder: list[int], isr: list[int], stack: int, script: str,
                 lost: int = 0) -> list[Budget]:
    """The timing budgets of one chip target's run (see the module's doc)."""
    from esair_min.pic.gpsim_bench import frame_slips

    c = robot.central
    target = run.target
    assert c.uart is not None and c.timer2 is not None
    if target == "pic":
        from esair_min.pic.gpsim_harness import GpsimSetup

        s: Any = GpsimSetup.from_robot(robot)
        unit = "instruction cycles"
    else:
        from esair_min.avr.simavr_harness import AvrSetup

        s = AvrSetup.from_robot(robot)
        unit = "cycles"
    byte = s.byte_cycles
    per_second = s.cycles_per_second
    out = []
    worst_isr = max(isr, default=0)
    char = max(decoder, default=0)
    need = char + worst_isr
    top_baud = int(10 * per_second / need) if need else 0
    out.append(Budget(target, "decoder per byte", need, byte, unit,
                      f"{char} worst byte + {worst_isr} worst ISR, {len(decoder)} bytes timed; "
                      f"one byte at {c.uart.baud} baud: {byte}",
                      f"lower uart.baud to at most {top_baud} (or raise mcu.clock_hz)"))
    if lost:
        out.append(Budget(target, "bytes lost in the decoder bench", lost, 0, "bytes",
                          f"at {c.uart.baud} baud the superloop did not take them in time",
                          f"lower uart.baud to at most {top_baud}"))
    out.append(Budget(target, "worst ISR", worst_isr, byte, unit,
                      f"{len(isr)} interrupts; one byte at {c.uart.baud} baud: {byte}",
                      f"lower uart.baud to at most {int(10 * per_second / max(1, worst_isr))}"))
    act = robot.peer("actuator")
    if act is not None and s.tick_cycles:
        writes, whole = tick_work(run.sim, act.address, 2 * len(robot.servos), s.tick_cycles)
        slips = frame_slips(_without_probes(run.sim), py.trace, act.address, s.tick_cycles)
        worst = max(writes, default=0)
        need_ms = worst / per_second * 1e3 * 1.1
        out.append(Budget(target, "tick: frame write", worst, s.tick_cycles, unit,
                          f"START to STOP of {len(writes)} full-frame writes; tick "
                          f"{c.timer2.period_ms:.3f} ms at {c.i2c.speed_hz} Hz I2C (the tick's "
                          f"whole bus work, with the next frame's read and a sensor poll: "
                          f"worst {max(whole, default=0)} after the tick)",
                          f"lengthen tick.period_ms to at least {need_ms:.2f} (with "
                          f"delay_ticks that let the next frame's read follow: esair check), "
                          f"raise i2c.speed_hz, or drive fewer servos"))
        out.append(Budget(target, "played frames slipped", slips.slipped, 0, "ticks",
                          f"motions played a frame a tick: ticks lost against the Python core "
                          f"(worst {slips.worst_late} late)",
                          "lengthen tick.period_ms or raise the motions' delay_ticks"))
    central = fw.builds["central"]
    ram = central.ram_bytes
    if target == "pic":
        from esair_min.codegen.context import PIC_STACK

        room, where = PIC_STACK["size"], f"SDCC's {PIC_STACK['size']} B stack section"
    else:
        room, where = ram - central.usage.data_bytes, (f"{ram} B RAM less "
                                                        f"{central.usage.data_bytes} B of data")
    out.append(Budget(target, "stack high-water", stack, room, "bytes", where,
                      "drive fewer servos or sensors, or drop reactions (each takes RAM), or "
                      "move the board to a part with more RAM"))
    return out


def memory_budgets(fw: Firmware, target: str, stack: int = 0) -> list[Budget]:
    """Flash and RAM of every board against its chip (an AVR central's stack included)."""
    out = []
    for role, b in sorted(fw.builds.items()):
        u = b.usage
        out.append(Budget(target, f"{role} flash", u.program_bytes, b.flash_bytes, "bytes",
                          b.part, "fewer motions, commands or servos on this board"))
        extra = stack if (role == "central" and b.part == "atmega328p") else 0
        out.append(Budget(target, f"{role} RAM", u.data_bytes + extra, b.ram_bytes, "bytes",
                          b.part + (" (with SDCC's stack)" if b.part == "pic18f452"
                                    else f" ({u.data_bytes} + {extra} B of stack)"
                                    if extra else ""),
                          "fewer servos, sensors or reactions on this board"))
    return out
