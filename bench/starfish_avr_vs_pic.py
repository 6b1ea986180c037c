"""STARFISH's boards on the ATmega328P (simavr) beside the PIC18F452 (gpsim), in one run:
both robots built (`esair build starfish-avr`, `esair build starfish`), then per board
flash and RAM, the central board's kinematics, velocity-line end and tick, and the
drive board's timer interrupt, in cycles and in time at each board's clock, with the
AVR/PIC ratio. Run: python bench/starfish_avr_vs_pic.py (~1-2 min). Prints figures; asserts
nothing (the exact values are asserted in tests/min/test_starfish_avr.py and
test_starfish_gpsim.py)."""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from esair_min.avr import starfish_simavr as avr_sf  # noqa: E402
from esair_min.model.validate import load_robot  # noqa: E402
from esair_min.pic import starfish_drive as pic_drive  # noqa: E402
from esair_min.pic.build import build_robot  # noqa: E402
from esair_min.pic.starfish_gpsim import measure_central  # noqa: E402
from esair_min.pic.toolchain import find_toolchain  # noqa: E402

LINE = "V-0345+0456-2789"
STEPS = [((300, -300, 300), 40)]


def row(what: str, avr: float, avr_hz: int, pic: float, pic_hz: int, unit: str = "cycles") -> None:
    if unit == "B":
        print(f"  {what:42s} AVR {avr:8.0f} B     PIC {pic:8.0f} B     AVR/PIC {avr / pic:.3f}")
        return
    ta, tp = avr / avr_hz * 1e6, pic / pic_hz * 1e6
    print(f"  {what:42s} AVR {avr:6.0f} = {ta:7.1f} us   PIC {pic:6.0f} = {tp:7.1f} us   "
          f"AVR/PIC time {ta / tp:.3f}")


def main() -> None:
    avr_robot = load_robot(ROOT / "boards" / "starfish-avr")
    pic_robot = load_robot(ROOT / "boards" / "starfish")
    avr_hz = avr_robot.central.mcu.clock_hz              # one cycle a clock
    pic_hz = pic_robot.central.mcu.clock_hz // 4         # one instruction cycle, 4 clocks
    tc = find_toolchain()
    with tempfile.TemporaryDirectory() as tmp:
        a_out, p_out = Path(tmp) / "avr", Path(tmp) / "pic"
        a_builds = {b.role: b.usage for b in build_robot(avr_robot, a_out)}
        p_builds = {b.role: b.usage for b in build_robot(pic_robot, p_out, tc)}
        print(f"STARFISH: ATmega328P at {avr_hz} Hz (simavr) vs PIC18F452 at "
              f"{pic_robot.central.mcu.clock_hz} Hz (gpsim)")
        for role in ("central", "drive"):
            a, p = a_builds[role], p_builds[role]
            row(f"{role} flash", a.program_bytes, 1, p.program_bytes, 1, "B")
            row(f"{role} RAM (AVR: + stack; PIC: with it)", a.data_bytes, 1, p.data_bytes, 1, "B")
        a = avr_sf.measure_central(avr_robot, a_out / "central" / "firmware.elf", LINE)
        pic = p_out / "central" / "build-pic"
        p = measure_central(pic_robot, pic / "firmware.cod", pic / "firmware.lst",
                            Path(tmp) / "g", LINE, tc)
        row("central core_kinematics", a.kinematics, avr_hz, p.kinematics, pic_hz)
        row(f"central CR of {LINE}", a.rx_line, avr_hz, p.rx_line, pic_hz)
        row("central one tick (6 flow reads)", a.tick, avr_hz, p.tick, pic_hz)
        ad = avr_sf.run_drive(avr_robot, a_out / "drive" / "firmware.elf", STEPS)
        pd = pic_drive.run_drive(pic_robot, p_out / "drive", STEPS, Path(tmp) / "d", tc)
        a_isr, p_isr = max(ad.isr_cycles), max(pd.isr_cycles)
        row("drive timer ISR, worst", a_isr, avr_hz, p_isr, pic_hz)
        print(f"  drive ISR histograms: AVR {dict(sorted(ad.isr_cycles.items()))} of "
              f"{avr_hz // 10_000} cycles a period; PIC {dict(sorted(pd.isr_cycles.items()))} "
              f"of {pic_hz // 10_000}")


if __name__ == "__main__":
    main()
