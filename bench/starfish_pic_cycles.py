"""STARFISH's central core on the PIC18F452 in gpsim (esair_min/pic/starfish_bench.py):
cycles of the kinematics, of a received byte, of a velocity line's end and of a tick,
against the budgets at the configured baud and tick; flash and RAM of the core with a
stub hal; then both boards' real PIC builds (esair build): their footprints against the
8 KB / 512 B goal (as a ratio), the port's kinematics, line end and tick
(esair_min/pic/starfish_gpsim.py) and the drive board's timer interrupt
(esair_min/pic/starfish_drive.py). Run: python bench/starfish_pic_cycles.py. Prints figures;
asserts nothing."""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from esair_min.codegen import generate_robot  # noqa: E402
from esair_min.model.validate import load_robot  # noqa: E402
from esair_min.pic.build import build_robot  # noqa: E402
from esair_min.pic.starfish_bench import measure_core  # noqa: E402
from esair_min.pic.starfish_drive import run_drive  # noqa: E402
from esair_min.pic.starfish_gpsim import measure_central  # noqa: E402
from esair_min.pic.toolchain import find_toolchain  # noqa: E402


def main() -> None:
    robot = load_robot(ROOT / "boards" / "starfish")
    central = robot.central
    ips = central.mcu.clock_hz // 4
    byte_budget = ips * 10 // central.uart.baud
    tick_budget = central.timer2.instructions
    with tempfile.TemporaryDirectory() as tmp:
        generate_robot(robot, Path(tmp) / "fw")
        got = measure_core(Path(tmp) / "fw" / "central",
                           ROOT / "tests" / "fixtures" / "pic" / "starfish_core_bench.c",
                           Path(tmp) / "pic", find_toolchain())
    print(f"STARFISH central core on the PIC18F452 at {central.mcu.clock_hz} Hz (gpsim, stub hal):")
    print(f"  kinematics (3 wheels, 32-bit):  {', '.join(map(str, got.kinematics))} cycles "
          f"= {max(got.kinematics) / ips * 1e3:.2f} ms")
    print(f"  a received byte (not a line end): {got.rx_char} cycles; budget at "
          f"{central.uart.baud} baud {byte_budget} ({got.rx_char / byte_budget:.1%})")
    print(f"  the CR of 'V-0345+0456-2789':   {got.rx_line} cycles "
          f"= {got.rx_line / ips * 1e3:.2f} ms ({got.rx_line / byte_budget:.1f} byte times)")
    print(f"  one tick (2 flow sensors read):  {got.tick} cycles; tick {tick_budget} "
          f"({got.tick / tick_budget:.1%})")
    print(f"  flash {got.usage.program_bytes} B, RAM {got.usage.data_bytes} B incl. a "
          f"{got.usage.stack_bytes} B stack (core + stub hal + SDCC library; goal per "
          "board 8192 B / 512 B)")
    ports(robot, ips, byte_budget, tick_budget)


def ports(robot, ips: int, byte_budget: int, tick_budget: int) -> None:
    tc = find_toolchain()
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "build"
        builds = build_robot(robot, out, tc)
        print("Both boards with their PIC ports (esair build):")
        for b in builds:
            u = b.usage
            print(f"  {b.role:8s} flash {u.program_bytes} B = {u.program_bytes / 8192:.3f} x the "
                  f"8192 B goal, RAM {u.data_bytes} B = {u.data_bytes / 512:.3f} x 512 B")
        pic = out / "central" / "build-pic"
        got = measure_central(robot, pic / "firmware.cod", pic / "firmware.lst",
                              Path(tmp) / "c", "V-0345+0456-2789", tc)
        print(f"  central: kinematics {got.kinematics} cycles ({got.kinematics / ips * 1e3:.2f} ms), "
              f"CR of the line {got.rx_line} ({got.rx_line / byte_budget:.1f} byte times), "
              f"tick {got.tick} ({got.tick / tick_budget:.1%} of the tick)")
        drive = run_drive(robot, out / "drive", [((300, -300, 300), 40)], Path(tmp) / "d", tc)
        period = robot.board("drive").mcu.clock_hz // 4 // 10_000
        worst = max(drive.isr_cycles)
        print(f"  drive: timer interrupt (2 CCP + 1 software PWM) {dict(sorted(drive.isr_cycles.items()))} "
              f"cycles: worst {worst} of the {period}-cycle period ({worst / period:.1%}, entry to RETFIE)")


if __name__ == "__main__":
    main()
