"""papaman-avr's sensor board before and after the analog mux (issue 24), side by side,
all exact (linker sizes, simavr cycles): two runs print the same numbers.

    python bench/avr_sensor_mux.py

before: six foot sensors on ADC0..ADC3, ADC6, ADC7 (the board file as it was: the TWI
takes ADC4/ADC5); after: boards/papaman-avr, eight foot sensors through a 74HC4051 on
ADC0 (select PB0..PB2, 10 us settling). For each: flash and RAM (avr-size: program =
.text + .data, RAM = .data + .bss), and the sensor board alone in simavr
(esair_min.avr.sensor): the cycles of one full read of every sensor, per sensor, and the
conversions the mux model saw start before the mux settled.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from esair_min.avr.build import build_board  # noqa: E402
from esair_min.avr.sensor import sensor_rounds  # noqa: E402
from esair_min.codegen import generate_robot  # noqa: E402
from esair_min.model.validate import load_robot  # noqa: E402

BOARDS = ROOT / "boards" / "papaman-avr"
#: The sensor board file before the mux (six channels, three a foot).
SIX = """\
board: sensor
role: sensor
mcu: {part: atmega328p, package: tqfp, clock_hz: 16000000}
i2c: {mode: slave, speed_hz: 100000, address: 0x20}
sensors:
  - {name: l_toe_in,   channel: 0, group: left_foot}
  - {name: l_toe_out,  channel: 1, group: left_foot}
  - {name: l_heel,     channel: 2, group: left_foot}
  - {name: r_toe_in,   channel: 3, group: right_foot}
  - {name: r_toe_out,  channel: 6, group: right_foot}
  - {name: r_heel,     channel: 7, group: right_foot}
"""
RUN_CYCLES = 400_000          # 25 ms at 16 MHz: 24 rounds of eight


def six_robot(work: Path) -> Path:
    folder = work / "six"
    folder.mkdir(parents=True)
    for path in BOARDS.glob("*.yaml"):
        text = path.read_text()
        if path.name == "central.yaml":
            text = text.replace("board: sensor, address: 0x20, registers: 16}",
                                "board: sensor, address: 0x20, registers: 12}")
        (folder / path.name).write_text(SIX if path.name == "sensor.yaml" else text)
    return folder


def measure(folder: Path, work: Path) -> tuple[int, int, int, int, set[int], int]:
    robot = load_robot(folder)
    generate_robot(robot, work)
    usage = build_board(work / "sensor")
    run = sensor_rounds(robot, work / "sensor" / "firmware.elf", RUN_CYCLES)
    return (len(robot.sensors), usage.program_bytes, usage.data_bytes, len(run.rounds),
            set(run.rounds), run.early)


def main() -> int:
    """The figures; the builds go in a temporary folder removed after (also on an error
    or Ctrl-C)."""
    with tempfile.TemporaryDirectory(prefix="esair-bench-avr-sensor-") as work:
        return _main(Path(work))


def _main(work: Path) -> int:
    rows = {"before (6 channels)": measure(six_robot(work), work / "six_fw"),
            "after (8 via mux)": measure(BOARDS, work / "mux_fw")}
    print("papaman-avr sensor board, ATmega328P at 16 MHz (exact)")
    print(f"  {'':20} {'sensors':>7} {'flash B':>8} {'RAM B':>6} {'full read (cycles)':>19} "
          f"{'per sensor':>10} {'early':>5}")
    for name, (n, flash, ram, count, rounds, early) in rows.items():
        cycles = "/".join(str(r) for r in sorted(rounds))
        per = "/".join(f"{r / n:.1f}" for r in sorted(rounds))
        print(f"  {name:20} {n:7} {flash:8} {ram:6} {cycles:>19} {per:>10} {early:5}"
              f"   ({count} rounds)")
    (n0, f0, r0, _, c0, _), (n1, f1, r1, _, c1, _) = rows.values()
    print(f"  after/before: flash {f1 / f0:.3f}x ({f1 - f0:+d} B), RAM {r1 / r0:.3f}x "
          f"({r1 - r0:+d} B), full read {max(c1) / max(c0):.3f}x for {n1 / n0:.3f}x the sensors "
          f"(one full read {max(c1) / 16e3:.3f} ms vs a 5-tick poll of 44.9 ms)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
