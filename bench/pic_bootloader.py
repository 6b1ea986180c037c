"""Exact figures of ESAIR's PIC18F452 serial bootloader (docs/bootloader.md).

    python bench/pic_bootloader.py [ROBOT]

Builds the robot with its bootloader (``esair build``), then writes the central
board's firmware-app.hex through the bootloader in gpsim at 115200 baud
(esair_min.pic.gpsim_line: the host answers at once, time is simulated) and prints:
the bootloader's size, the application's flash before and after the relocation, and
the flash's time against its floor: the image's bytes on the wire once plus the
datasheet's erase and write times of its rows (2 ms each, TIW: one erase and eight
8-byte writes a 64-byte row). Deterministic: two runs print the same numbers.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from esair_min.flash.pic import Bootloader, load_image, write_image  # noqa: E402
from esair_min.model import picboot  # noqa: E402
from esair_min.model.validate import load_robot  # noqa: E402
from esair_min.pic.build import build_robot, summary_lines  # noqa: E402
from esair_min.pic.gpsim_i2c import GpsimSession  # noqa: E402
from esair_min.pic.gpsim_line import SimLine  # noqa: E402
from esair_min.resources import resolve_robot  # noqa: E402

TIW_S = 0.002                                  # self-timed erase or write, typical
REPLY = {"W": 2, "G": 2, "H": 7, "R": 66}      # bytes of each command's answer


def exchanges(line: SimLine) -> list[tuple[str, int, int]]:
    """(command, first byte of the frame on the line, end of the answer's last byte)."""
    out, tx = [], list(line.tx_cycles)
    for start, sent in line.writes:
        cmd = chr(sent[0])
        answer = [c for c in tx if c >= start][:REPLY[cmd]]
        tx = [c for c in tx if c > answer[-1]]
        out.append((cmd, start, answer[-1] + line.byte_cycles))
    return out


def main(argv: list[str]) -> int:
    robot = load_robot(resolve_robot(argv[0] if argv else "papaman"))
    with tempfile.TemporaryDirectory() as tmp:
        builds = build_robot(robot, Path(tmp) / "fw", boot=True)
        for line in summary_lines(builds):
            print(line)
        central = next(b for b in builds if b.role == "central" and b.boot is not None)
        boot = central.boot
        assert boot is not None
        image = load_image(central.folder / "firmware-app.hex")
        s = GpsimSession(Path(tmp), timeout=1200).start(
            central.folder / "build-boot" / "bootloader.cod", 20_000_000)
        line = SimLine(s, Path(tmp), 20_000_000, picboot.BOOT_BAUD)
        write_image(Bootloader(line, "gpsim"), image)
        s.close()
    rate = 5_000_000
    ex = exchanges(line)
    total = sum(end - start for _, start, end in ex) / rate
    by = {c: sum(e - s for k, s, e in ex if k == c) / rate for c in REPLY}
    rows = len(image.rows) + 1
    flash_bytes = rows * picboot.ROW + sum(len(d) for d in image.eeprom.values())
    wire = flash_bytes * 10 / picboot.BOOT_BAUD
    floor = wire + rows * 9 * TIW_S
    print()
    print(f"bootloader: {boot.bootloader_bytes} B of the {picboot.BOOT_END}-byte boot block")
    print(f"application: {central.usage.program_bytes} B linked at 0x0000, "
          f"{boot.app_bytes} B above the bootloader (0x{picboot.APP_START:04X}.."
          f"0x{boot.app_end - 1:04X}: {rows - 1} rows + the record row)")
    print(f"flash at {picboot.BOOT_BAUD} baud: {total:.3f} s of line and chip time "
          f"({len(ex)} exchanges: hello {by['H']:.3f}, write {by['W']:.3f}, "
          f"read back {by['R']:.3f}, go {by['G']:.3f})")
    print(f"floor: {wire:.3f} s on the wire ({flash_bytes} B once) + {rows * 9 * TIW_S:.3f} s "
          f"erasing and writing ({rows} rows x 9 x 2 ms) = {floor:.3f} s")
    print(f"ratio: {total / floor:.2f} (goal 1.5); writing alone {by['W'] / floor:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
