"""STARFISH's central core on the PIC18F452 in gpsim (esair_min/pic/starfish_bench.py):
cycles of the kinematics, of a received byte, of a velocity line's end and of a tick,
against the budgets at the configured baud and tick; flash and RAM of the core with a
stub hal. Run: python bench/starfish_pic.py. Prints figures; asserts nothing."""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from esair_min.codegen import generate_robot  # noqa: E402
from esair_min.model.validate import load_robot  # noqa: E402
from esair_min.pic.starfish_bench import measure_core  # noqa: E402
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


if __name__ == "__main__":
    main()
