"""ATmega328P figures beside the PIC18F452's (issue 24), all exact (simulator cycles,
linker sizes): two runs print the same numbers.

    python bench/avr_vs_pic.py [--no-pic]

1. Flash and RAM of every board on each MCU: boards/papaman built with SDCC for the
   PIC18F452, boards/papaman-avr with avr-gcc for the ATmega328P.
2. The central board's interrupts on the AVR in simavr (tests/fixtures/gpsim/papaman.txt):
   cycles from vectoring to RETI per vector, and the receive ISR's cycles per byte as a
   share of the byte time at 9600 and 115200 baud (the USART holds 3 bytes: an ISR may
   be late by up to two byte times before one is lost); and the decoder's drain loop per
   received byte (60 bytes waiting in the ring, drained back to back).
3. Servo pulses on the AVR actuator while all three boards dance in lockstep: error of
   every pulse against the position its writes and sync edges command (goal 1 %).
4. Bus time per transfer kind: the emulator (wire + the master's overhead,
   esair_min.model.mcu.BusOverhead) against the PIC in gpsim and the AVR in simavr, with
   the wire time alone for comparison; and the least-squares fit of the overhead from
   these runs beside the constants the emulator uses.
"""

from __future__ import annotations

import statistics
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from esair_min.avr.simavr_harness import run_robot, run_stimulus, symbol  # noqa: E402
from esair_min.avr.servo import checked_pulses  # noqa: E402
from esair_min.emulator.i2c import transfer_ns  # noqa: E402
from esair_min.model import mcu  # noqa: E402
from esair_min.model.hardware import write_bits, write_read_bits  # noqa: E402
from esair_min.model.validate import load_robot  # noqa: E402
from esair_min.pic.build import build_robot  # noqa: E402
from esair_min.pic.gpsim_wave import transfer_kinds  # noqa: E402

SCENARIO = ROOT / "tests" / "fixtures" / "gpsim" / "papaman.txt"
DANCE = ("sensor 500 500 500 500 500 500 500 500\nboot\ntick 4\nrx DNC\\r\ntick 40\nrx x\\r\ntick 12\n")
VECTORS = {11: "TIMER1_COMPA (tick)", 18: "USART_RX", 19: "USART_UDRE"}


def table(rows: list[tuple[str, ...]]) -> None:
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    for r in rows:
        print("  " + "  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip())


def solve(a: list[list[float]], b: list[float]) -> list[float]:
    """Least squares by the normal equations (4 unknowns)."""
    n = len(a[0])
    m = [[sum(r[i] * r[j] for r in a) for j in range(n)] + [sum(r[i] * y for r, y in zip(a, b, strict=True))]
         for i in range(n)]
    for i in range(n):
        p = max(range(i, n), key=lambda k: abs(m[k][i]))
        m[i], m[p] = m[p], m[i]
        for k in range(n):
            if k != i:
                f = m[k][i] / m[i][i]
                m[k] = [x - f * y for x, y in zip(m[k], m[i], strict=True)]
    return [m[i][n] / m[i][i] for i in range(n)]


def fit(kinds: dict, bit_cycles: float) -> list[float]:
    a, b = [], []
    for (nw, nr), v in kinds.items():
        bits = write_bits(nw) if nr is None else write_read_bits(nw, nr)
        a.append([1.0 if nr is None else 0.0, 0.0 if nr is None else 1.0, nw, nr or 0])
        b.append(statistics.median(v) - bits * bit_cycles)
    return solve(a, b)


def main(argv: list[str]) -> int:
    """The figures; the builds go in a temporary folder removed after (also on an error
    or Ctrl-C)."""
    with tempfile.TemporaryDirectory(prefix="esair-bench-avr-") as work:
        return _main(argv, Path(work))


def _main(argv: list[str], work: Path) -> int:
    pic = "--no-pic" not in argv
    avr_robot = load_robot(ROOT / "boards" / "papaman-avr")
    pic_robot = load_robot(ROOT / "boards" / "papaman")

    print("1. Flash / RAM per board (bytes; PIC RAM includes SDCC's 128-byte stack, AVR RAM "
          "is .data+.bss, its stack measured below)")
    avr_builds = {b.role: b for b in build_robot(avr_robot, work / "avr")}
    pic_builds = {b.role: b for b in build_robot(pic_robot, work / "pic")} if pic else {}
    rows = [("board", "PIC18F452 program", "PIC RAM", "ATmega328P flash", "AVR RAM", "flash AVR/PIC")]
    for role in ("central", "actuator", "sensor"):
        a = avr_builds[role].usage
        p = pic_builds[role].usage if pic else None
        rows.append((role, str(p.program_bytes) if p else "-", str(p.data_bytes) if p else "-",
                     str(a.program_bytes), str(a.data_bytes),
                     f"{a.program_bytes / p.program_bytes:.2f}x" if p else "-"))
    table(rows)
    print("  goal (central, AVR): <= 8192 flash, <= 1024 RAM; StandardFirmata: 11844 / 862")

    elfs = {role: b.folder / "firmware.elf" for role, b in avr_builds.items()}
    run = run_stimulus(avr_robot, SCENARIO.read_text(), elfs["central"],
                       work / "scenario", isrs=True)
    c = avr_robot.central
    print(f"\n2. Central board's interrupts on the AVR (cycles at {c.mcu.clock_hz} Hz; "
          f"stack {run.stack_bytes} B deepest)")
    spans = run.isr_spans()
    rows = [("vector", "n", "mean", "worst")]
    for v, s in sorted(spans.items()):
        rows.append((VECTORS.get(v, str(v)), str(len(s)), f"{statistics.fmean(s):.1f}", str(max(s))))
    table(rows)
    rx = spans.get(18, [])
    worst_any = max(max(s) for s in spans.values())
    for baud in (9600, 115200):
        byte = 10 * c.mcu.clock_hz / baud
        print(f"  at {baud} baud a byte is {byte:.0f} cycles: RX ISR worst {max(rx)} = "
              f"{max(rx) / byte:.3f} of it; the worst ISR of any kind {worst_any} = "
              f"{worst_any / byte:.3f} (a byte is lost only past 2 byte times)")

    # the decoder: a held t, then 60 ordinary bytes that wait in the ring (at 250000 baud,
    # exact at 16 MHz) and are drained back to back when the tick releases the hold: the
    # cycles between successive entries of hal_uart_rx are the drain loop's per byte
    fast = work / "fast" / "papaman-avr"
    fast.mkdir(parents=True)
    for path in (ROOT / "boards" / "papaman-avr").glob("*.yaml"):
        (fast / path.name).write_text(path.read_text().replace("baud: 9600", "baud: 250000"))
    fast_robot = load_robot(fast)
    fast_builds = {b.role: b for b in build_robot(fast_robot, work / "fastfw")}
    fast_elf = fast_builds["central"].folder / "firmware.elf"
    drun = run_stimulus(fast_robot, "boot\nrx t\\r" + "0123456789" * 6 + "\\r\ntick 3\n", fast_elf,
                        work / "decoder", watch=(symbol(fast_elf, "hal_uart_rx"),))
    release = next(t for t in drun.transfers if t.segments[0].address == 0x10).stop
    hits = [cyc for cyc, _ in drun.hits if cyc > release][:60]
    per_byte = [b - a for a, b in zip(hits, hits[1:], strict=False)]
    print(f"  decoder drain loop per ordinary byte (59 back to back): mean "
          f"{statistics.fmean(per_byte):.1f}, worst {max(per_byte)} cycles (the PIC: 36 "
          f"instruction cycles = 144 clock cycles); budget at 115200 baud {10 * 16e6 / 115200:.0f}")

    dance = run_robot(avr_robot, DANCE, elfs, work / "dance")
    checks, skipped = checked_pulses(dance, avr_robot, c.mcu.clock_hz)
    errs = [abs(x.error) for x in checks]
    print(f"\n3. Servo pulses under load (three boards dancing, a frame every tick): {len(checks)} "
          f"pulses ({skipped} within 1 ms of a latch left out), worst error "
          f"{100 * max(errs):.3f} %, mean {100 * statistics.fmean(errs):.4f} % (goal 1 %: "
          f"{max(errs) / 0.01:.3f} of it)")

    print("\n4. Bus time per transfer kind (us): emulator (wire + overhead) vs simulators")
    avr_kinds = transfer_kinds(run.transfers)
    pic_kinds = {}
    if pic:
        from esair_min.pic.gpsim_harness import run_stimulus as gpsim_run
        prun = gpsim_run(pic_robot, SCENARIO.read_text(), pic_builds["central"].cod, work / "gpsim")
        pic_kinds = transfer_kinds(prun.transfers)
    rows = [("kind (written, read)", "wire", "emu PIC", "PIC gpsim", "emu/PIC", "wire/PIC",
             "emu AVR", "AVR simavr", "emu/AVR")]
    pc, ac = pic_robot.central, avr_robot.central

    def emu(board, nw, nr):
        part, clock = board.mcu.part, board.mcu.clock_hz
        return transfer_ns(board.i2c.speed_hz, nw, nr,
                           lambda w, r: mcu.bus_overhead_ns(part, clock, w, r)) / 1e3

    for key in sorted(set(pic_kinds) | set(avr_kinds), key=lambda k: (k[1] is None, k)):
        nw, nr = key
        wire = transfer_ns(100_000, nw, nr) / 1e3
        p = statistics.median(pic_kinds[key]) * 4e6 / pc.mcu.clock_hz if key in pic_kinds else None
        a = statistics.median(avr_kinds[key]) * 1e6 / ac.mcu.clock_hz if key in avr_kinds else None
        ep, ea = emu(pc, nw, nr), emu(ac, nw, nr)
        rows.append((f"{nw}, {'-' if nr is None else nr}", f"{wire:.1f}", f"{ep:.1f}",
                     f"{p:.1f}" if p else "-", f"{ep / p:.4f}" if p else "-",
                     f"{wire / p:.3f}" if p else "-", f"{ea:.1f}", f"{a:.1f}" if a else "-",
                     f"{ea / a:.4f}" if a else "-"))
    table(rows)
    print("  overhead fit (cycles: write fixed, read fixed, per byte written, per byte read)")
    for name, kinds, bit, spec in (("PIC18F452", pic_kinds, 50.0, mcu.PIC18F452),
                                   ("ATmega328P", avr_kinds, 160.0, mcu.ATMEGA328P)):
        if kinds:
            got = fit(kinds, bit)
            used = spec.bus_overhead
            print(f"  {name}: fitted {', '.join(f'{x:.1f}' for x in got)}; used "
                  f"{used.write_fixed}, {used.read_fixed}, {used.per_write_byte}, {used.per_read_byte}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
