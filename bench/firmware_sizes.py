"""Exact figures of PAPA-MAN's PIC18F452 firmware, from gplink maps and gpsim cycles.

    python bench/firmware_sizes.py [ROBOT]

Generates and builds every board (``esair build``), prints the footprint table, then
runs the central firmware in gpsim on tests/fixtures/gpsim/papaman.txt and prints:
the decoder's instruction cycles per received byte (ordinary bytes through the inline
fast path, and each line end through core_rx_end, as ratios of the per-byte budget at 115200
baud and at the board's own baud), the
interrupt routine's cycles, and the frame timing on the I2C bus (sync tick to the last
byte of a frame write, bus time of a frame write and of a frame read, as ratios of the
tick). Everything is deterministic: two runs print the same numbers.
"""

from __future__ import annotations

import statistics
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from esair_min.pic.build import build_robot, summary_lines  # noqa: E402
from esair_min.pic.gpsim_bench import describe, frame_slips, frame_timing, measure_decoder  # noqa: E402
from esair_min.pic.gpsim_harness import GpsimSetup, compare, run_stimulus  # noqa: E402
from esair_min.core.stimulus import run_script  # noqa: E402
from esair_min.resources import resolve_robot  # noqa: E402
from esair_min.model.validate import load_robot  # noqa: E402

SCENARIO = ROOT / "tests" / "fixtures" / "gpsim" / "papaman.txt"
GOAL_PER_BYTE = 40


def main(argv: list[str]) -> int:
    robot = load_robot(resolve_robot(argv[0] if argv else "papaman"))
    stimulus = SCENARIO.read_text()
    setup = GpsimSetup.from_robot(robot)
    cps = setup.cycles_per_second
    budget_115200 = cps * 10 // 115200
    budget_own = cps * 10 // setup.baud
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        builds = build_robot(robot, work / "fw")
        print("footprint (gplink maps):")
        for line in summary_lines(builds):
            print("  " + line)
        central = next(b for b in builds if b.role == "central")
        cod, lst = central.cod, central.folder / "build-pic" / "firmware.lst"

        run = run_stimulus(robot, stimulus, cod, work / "run")
        diffs = compare(run_script(robot, stimulus), run.trace(), setup)
        print(f"\ngpsim vs Python core on {SCENARIO.name}: "
              + ("replies, actuator writes and EEPROM reads equal" if not diffs
                 else "DIFFERENT: " + "; ".join(diffs)))

        fig = measure_decoder(robot, stimulus, cod, lst, work / "bench")
        worst, mean = max(fig.chars), statistics.fmean(fig.chars)
        everything = fig.all_bytes
        print(f"\ndecoder (the superloop's drain loop from the byte in hand to the branch "
              f"back to its head, interrupts subtracted), {fig.total_bytes} bytes:")
        print(f"  ordinary bytes (all but CR/LF, {fig.interrupted_chars} with an interrupt "
              f"inside left out; inline fast path for "
              f"{len(fig.chars) + fig.interrupted_chars - fig.slow_chars} of "
              f"{len(fig.chars) + fig.interrupted_chars}): "
              f"{describe(fig.chars)} cycles; worst = "
              f"{worst / budget_115200:.3f} of the {budget_115200}-cycle budget at 115200 "
              f"baud, {worst / budget_own:.4f} of {budget_own} at {setup.baud}; "
              f"goal {GOAL_PER_BYTE}: worst is {worst / GOAL_PER_BYTE:.2f}x, mean "
              f"{mean / GOAL_PER_BYTE:.2f}x")
        print(f"  all bytes (line ends run the whole command): mean "
              f"{statistics.fmean(everything):.0f} cycles = "
              f"{statistics.fmean(everything) / budget_own:.3f} of the {setup.baud}-baud budget")
        print(f"  line ends (slow path: core_rx_end for {fig.slow_ends} of "
              f"{len(fig.line_ends)}), costliest first (cycles; the command, its I2C "
              f"transfers and waits for room in the transmit ring included):")
        seen: dict[str, int] = {}
        for line, cycles in fig.line_ends:
            seen[line] = max(seen.get(line, 0), cycles)
        for line, cycles in sorted(seen.items(), key=lambda kv: -kv[1]):
            print(f"    {cycles:>7}  {cycles / budget_own:7.2f} byte times  {line[:44]}")
        print(f"\ninterrupt routine (vector 0x0008 to end of RETFIE): all {describe(fig.isr)}; "
              f"with a Timer2 tick {describe(fig.isr_tick)}; tick alone "
              f"{min(fig.isr_tick)} cycles")

        tick = setup.tick_cycles
        t = frame_timing(run, setup.actuator_address, setup.eeprom_address,
                         2 * len(robot.servos), tick)
        bit = cps // robot.central.i2c.speed_hz      # instruction cycles per I2C bit
        wire = (2 * len(robot.servos) + 2) * 9 * bit
        read_wire = (2 * len(robot.servos) + 4) * 9 * bit
        slips = frame_slips(run, run_script(robot, stimulus), setup.actuator_address, tick)
        dance = sum(1 for _, p in slips.gaps if p == 1)
        print(f"\nframes on the I2C bus (tick = {tick} cycles = {tick / cps * 1e3:.4f} ms):")
        if t.played:
            worst = max(t.played)
            print(f"  sync tick -> last byte of a frame write, frames played one per tick: "
                  f"{describe(t.played)}, best {min(t.played)} cycles; worst "
                  f"{worst / cps * 1e3:.3f} ms = "
                  f"{worst / tick:.3f} of the tick (goal 0.25; the wire alone needs "
                  f"{wire} = {wire / tick:.3f})")
        print(f"  every frame write (commands' writes wait for the command's own I2C "
              f"work): {describe(t.to_last_byte)} cycles, best {min(t.to_last_byte)}")
        print(f"  frame write START..STOP: {describe(t.write)} = {max(t.write) / tick:.3f} "
              f"of the tick = {max(t.write) / wire:.3f}x the wire ({wire}); frame read: "
              f"{describe(t.read)} = {max(t.read) / tick:.3f} of the tick = "
              f"{max(t.read) / read_wire:.3f}x the wire ({read_wire})")
        print(f"  write + read of the next frame = {(max(t.write) + max(t.read)) / tick:.3f} "
              f"of the tick; the dance ({dance} consecutive-tick frames): {slips.slipped} "
              f"slipped ticks, worst {slips.worst_late} ticks late")
    return 1 if diffs else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
