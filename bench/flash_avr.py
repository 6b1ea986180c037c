"""``esair flash`` of papaman-avr's central board through the simulated Uno (issue 32):
the real avrdude 7.1, the real bootloaders, the chip in simavr in real time (its page
erase and write 4.5 ms each, the datasheet's maximum), against the floor: the image's
bytes on the wire at the bootloader's baud (10 bits a byte), once to write and once to
read back for the verify.

    python bench/flash_avr.py [RUNS]

Per bootloader: the write and the verify as avrdude times them, the whole command
(esair's start, the reset, the sync, write, verify), and each against its floor.
Wall-clock times on a shared machine: the median of RUNS (default 3) is shown.
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from esair_min.avr.uno import SimUno, new_chip  # noqa: E402
from esair_min.flash.avrdude import BOOTLOADER_BAUD, AvrFlash, flash_avr  # noqa: E402
from esair_min.flash.firmware import firmware  # noqa: E402
from esair_min.model.validate import load_robot  # noqa: E402

BOARDS = ROOT / "boards" / "papaman-avr"


def one(work: Path, hex_path: Path, bootloader: str) -> tuple[float, float, float, float]:
    """(write s, verify s, whole s, the write in the chip's time) of one flash of a fresh
    chip. The chip's time (its cycles from the first page written to the last, per page
    times the pages) does not stretch when a loaded machine runs the simulation slower
    than real time; avrdude's turnaround between pages is in it at whatever pace the
    simulation ran."""
    import re

    chip = work / f"{bootloader}.bin"
    with SimUno(chip, work / "tty", new_chip(chip, bootloader)) as uno:
        start = time.monotonic()
        r = subprocess.run([sys.executable, "-m", "esair_min.cli", "flash", str(BOARDS),
                            "--board", "central", "--port", str(uno.port), "-o",
                            str(work / "build"), "--bootloader", bootloader, "--attempts",
                            "1"], capture_output=True, text=True, timeout=300,
                           env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"})
        whole = time.monotonic() - start
        if r.returncode != 0:
            raise SystemExit(r.stderr)
        pages = [int(e.split()[1]) for e in uno.events if e.startswith("page ")]
        chip_write = (pages[-1] - pages[0]) / (len(pages) - 1) * len(pages) / uno.clock_hz
    # the same avrdude run again, in process, for avrdude's own phase times
    chip.unlink()
    with SimUno(chip, work / "tty", new_chip(chip, bootloader)) as uno:
        out = flash_avr(AvrFlash(hex_path, str(uno.port), bootloader=bootloader, attempts=1))
    times = [float(t) for t in re.findall(r"\| 100% ([0-9.]+)s", out)]
    return times[0], times[1], whole, chip_write


def main() -> None:
    runs = int(sys.argv[1]) if len(sys.argv) > 1 else 3
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        fw = firmware(load_robot(BOARDS), work / "build", "central")
        size = fw.image_bytes()
        print(f"papaman-avr central: {size} bytes of flash ({(size + 127) // 128} pages)")
        print("bootloader   baud    floor (write / +verify)   write (chip time)   write (wall)"
              "     verify (wall)    whole command (wall)")
        for bootloader, baud in BOOTLOADER_BAUD.items():
            floor = size * 10 / baud
            got = [one(work, fw.hex_path, bootloader) for _ in range(runs)]
            w, v, t, c = (statistics.median(x) for x in zip(*got, strict=True))
            print(f"{bootloader:<12} {baud:<7} {floor:.3f} s / {2 * floor:.3f} s       "
                  f"{c:.3f} s ({c / floor:.2f}x)    {w:.2f} s ({w / floor:.2f}x)  "
                  f"{v:.2f} s ({v / floor:.2f}x)  {t:.2f} s ({t / (2 * floor):.2f}x)")
        print(f"load average while measuring: {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")


if __name__ == "__main__":
    main()
