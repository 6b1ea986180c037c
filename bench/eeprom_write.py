"""The motion image written over the robot's own link (issue 32 item 2): the write's
time against the line's floor, in the emulator's virtual time (exact, no host noise).

The floor is what the line itself needs for this protocol: every write line (the
chunk's address, data and checksum in hex, its line end) at the board's baud, 10 bits
a character, plus one EEPROM write cycle (5 ms) per page write. The write measured
reads every chunk first (only the ones that differ are written), writes them, commits
(the board reads the whole image back and checks its CRC) and asks ``v``.

    python bench/eeprom_write.py [ROBOT]      # default papaman
"""

from __future__ import annotations

import sys

from esair_min.core import protocol as P
from esair_min.core.image import build_image
from esair_min.emulator.clock import NS_PER_S
from esair_min.emulator.eeprom_chip import T_WC_NS
from esair_min.imagelink import ImageLink
from esair_min.serialport import open_port
from esair_min.resources import resolve_robot
from esair_min.model.validate import load_robot


def measure(robot_arg: str = "papaman") -> dict[str, float]:
    robot = load_robot(resolve_robot(robot_arg))
    image = build_image(robot)
    port = open_port(f"esair://{resolve_robot(robot_arg)}?speed=max&eeprom=blank", timeout=0.05)
    emu = port.emulator
    link = ImageLink(port, robot)
    baud = robot.central.uart.baud
    lines = [P.frame_line(P.encode_image_write(at, image[at:at + n], link.p_write),
                          link.checksum) for at, n in link.chunks(len(image))]
    wire_s = sum(len(x) for x in lines) * 10 / baud
    t0, cycles0 = emu.clock.now, emu.eeprom_bus.cycles
    res = link.write_image(image)
    took = (emu.clock.now - t0) / NS_PER_S
    cycles = emu.eeprom_bus.cycles - cycles0
    floor = wire_s + cycles * T_WC_NS / NS_PER_S
    raw_s = len(image) * 10 / baud
    port.close()
    return {"bytes": len(image), "chunks": res.chunks, "written": res.written,
            "page_writes": cycles, "baud": baud, "write_s": took, "floor_s": floor,
            "ratio": took / floor, "raw_bytes_s": raw_s, "ratio_raw": took / raw_s}


def main() -> None:
    m = measure(sys.argv[1] if len(sys.argv) > 1 else "papaman")
    print(f"image {m['bytes']} B in {m['chunks']} chunks ({m['written']} written, "
          f"{m['page_writes']} page writes) at {m['baud']} baud")
    print(f"write {m['write_s']:.3f} s (virtual), floor {m['floor_s']:.3f} s: "
          f"{m['ratio']:.3f}x  (raw image bytes alone on the wire: {m['raw_bytes_s']:.3f} s, "
          f"{m['ratio_raw']:.2f}x)")


if __name__ == "__main__":
    main()
