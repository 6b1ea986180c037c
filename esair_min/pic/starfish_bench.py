"""Cycle counts of STARFISH's central core on the PIC18F452, measured in gpsim.

The generated core (``core/omni.c``) alone, linked with a stub hal and a fixed main
(tests/fixtures/pic/starfish_core_bench.c; the port's build is timed by
:func:`esair_min.pic.starfish_gpsim.measure_central`): two calls of ``core_kinematics``, the
line ``V-0345+0456-2789`` byte by byte into ``core_rx``, then
one ``core_tick`` (two flow sensors read, no watchdog). Execution breakpoints on each
function's entry and returns (addresses from gplink's listing), ``cycles`` at each hit.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from esair_min.pic.gpsim_bench import RETURN_CYCLES, function_spans, parse_hits
from esair_min.pic.toolchain import (MapUsage, Toolchain, ToolchainError, _run, parse_map,
                                     run_gpsim, sdcc_flags)


@dataclass(frozen=True)
class CoreCycles:
    kinematics: tuple[int, ...]     # each call of core_kinematics
    rx_char: int                    # core_rx of a byte that does not end the line
    rx_line: int                    # core_rx of the CR of the velocity line
    tick: int                       # core_tick
    usage: MapUsage                 # the core + stubs + SDCC's library


def _build(central: Path, main_c: Path, work: Path, tc: Toolchain) -> Path:
    work.mkdir(parents=True, exist_ok=True)
    inc = [f"-I{central}", f"-I{central / 'core'}"]
    objs = []
    for src in (central / "core" / "omni.c", main_c):
        obj = src.stem + ".o"
        _run([str(tc.sdcc), *sdcc_flags(tc), *inc, "-c", str(src.resolve()), "-o", obj],
             work, 300)
        objs.append(obj)
    _run([str(tc.sdcc), *sdcc_flags(tc, link=True), *objs, "-o", "bench.hex"], work, 300)
    return work / "bench.cod"


def measure_core(central: Path, main_c: Path, work: Path, tc: Toolchain) -> CoreCycles:
    """``central``: the generated central board's folder."""
    _build(central, main_c, work, tc)
    spans = function_spans((work / "bench.lst").read_text(errors="replace"))
    names = {}
    for fn in ("_core_kinematics", "_core_rx", "_core_tick"):
        if fn not in spans or not spans[fn].exits:
            raise ToolchainError(f"bench.lst: no function {fn} with a return")
        names[spans[fn].entry] = (fn, True)
        names.update({a: (fn, False) for a in spans[fn].exits})
    lines = ["load bench.cod", "p18f452.BreakOnInvalidRegisterWrite = false",
             "frequency 20000000"] + [f"break e {a:#x}" for a in sorted(names)]
    lines += ["break c 2000000"] + ["run", "cycles"] * 45
    hits = parse_hits(run_gpsim("\n".join(lines) + "\nquit\n", work, timeout=300, tc=tc))
    spans_of: dict[str, list[int]] = {fn: [] for fn in ("_core_kinematics", "_core_rx",
                                                        "_core_tick")}
    open_at: dict[str, int] = {}
    for h in hits:
        fn, entry = names[h.addr]
        if entry:
            open_at.setdefault(fn, h.cycle)
        elif fn in open_at:
            spans_of[fn].append(h.cycle + RETURN_CYCLES - open_at.pop(fn))
    kin, rx, tick = spans_of["_core_kinematics"], spans_of["_core_rx"], spans_of["_core_tick"]
    if len(kin) < 3 or len(rx) < 17 or not tick:
        raise ToolchainError(f"gpsim: {len(kin)} kinematics, {len(rx)} rx, {len(tick)} tick "
                             "spans timed (expected 3, 17, 1)")
    return CoreCycles(tuple(kin[:3]), rx[0], rx[16], tick[0], parse_map(work / "bench.map"))
