"""STARFISH's serial line budget at each baud the central board could use (issue 23):
what one ``O`` poll (the longest reply) and one ``V`` wheel command take on the wire,
and the share of the line that 10 odometry polls a second plus the behaviors' wheel
commands (20 and 50 a second) take, beside the baud error of the PIC18F452 at the board
file's clock (the validator refuses more than 2 %). Prints the table docs/std-starfish.md
gives; the board file's own baud is marked.

    python bench/starfish_line_budget.py
"""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from esair_min.model.hardware import best_baud  # noqa: E402
from esair_min.model.validate import load_robot  # noqa: E402
from esair_min.resources import resolve_robot  # noqa: E402
from esair_std.drivers.starfish.omnilink import omni_budget  # noqa: E402

V_LINE = len("V+0100+0000+0000\r\n")
OK_REPLY = len("OK\r\n")
ODOMETRY_HZ = 10


def main() -> None:
    robot = load_robot(resolve_robot("starfish"))
    clock = robot.central.mcu.clock_hz
    base = omni_budget(robot)
    print(f"STARFISH central at {clock / 1e6:g} MHz; board file: {base.baud} baud")
    print(f"{'baud':>7} {'error':>7} {'O ms':>6} {'V ms':>6} {'max O/s (half)':>15} "
          f"{'10 O + 20 V':>12} {'10 O + 50 V':>12}")
    for baud in (9600, 19200, 38400, 57600, 115200):
        b = dataclasses.replace(base, baud=baud)
        err = best_baud(clock, baud).error_percent
        o = b.feet_exchange_s
        v = b.command_s(V_LINE, OK_REPLY, waits_tick=False)
        load = [ODOMETRY_HZ * o + n * v for n in (20, 50)]
        mark = " <- board file" if baud == base.baud else ""
        print(f"{baud:>7} {err:>+6.2f}% {o * 1e3:>6.1f} {v * 1e3:>6.2f} {b.max_feet_hz(0.5):>15.1f} "
              f"{load[0]:>11.2f}x {load[1]:>11.2f}x{mark}")


if __name__ == "__main__":
    main()
