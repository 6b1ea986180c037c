"""The central board's !READY and v lines for a robot, as its firmware sends them: with
the image's CRC (when valid) and the firmware's build id (codegen.buildid)."""

from __future__ import annotations

from esair_min.codegen.buildid import central_build_id
from esair_min.core import protocol as P
from esair_min.core.image import build_image
from esair_min.model.robot import Robot


def image_crc(robot: Robot) -> int:
    return int.from_bytes(build_image(robot)[6:8], "little")


def ready(robot: Robot, ok: bool = True) -> bytes:
    """``!READY ...`` with CR LF."""
    return P.ready_line(ok, image_crc(robot), central_build_id(robot))


def version(robot: Robot, ok: bool = True, checksum: bool = False,
            robot_id: str | None = None) -> bytes:
    """The ``v`` reply with CR LF."""
    return P.ok_line(P.version_data(len(robot.servos), len(robot.sensors), len(robot.motions),
                                    ok, checksum, robot_id, image_crc(robot),
                                    central_build_id(robot)))


def text(line: bytes) -> str:
    return line.decode().rstrip("\r\n")


def _papaman() -> Robot:
    from pathlib import Path

    from esair_min.model.validate import load_robot
    return load_robot(Path(__file__).resolve().parents[2] / "boards" / "papaman")


PAPAMAN = _papaman()
#: PAPA-MAN's lines (bytes with CR LF), its image valid or not
READY_OK, READY_BAD = ready(PAPAMAN), ready(PAPAMAN, False)
VERSION_OK, VERSION_BAD = version(PAPAMAN), version(PAPAMAN, False)
#: the same as text (no CR LF)
READY_OK_T, READY_BAD_T = text(READY_OK), text(READY_BAD)
VERSION_OK_T, VERSION_BAD_T = text(VERSION_OK), text(VERSION_BAD)


def eeprom_stimulus(robot: Robot, scan: bool = True) -> str:
    """A stimulus script (docs/trace-format.md) of the image verbs and their refusals:
    i2c_scan (``scan``), the header chunk (the write opens), a play refused, a chunk, a
    bad checksum, a chunk across a page, a read, the commit, v, a play (of one frame:
    the simulators take the line at its rate, the Python core at once)."""
    image = build_image(robot)
    bad = P.encode_image_write(16, image[16:32])
    bad = bad[:-1] + ("0" if bad[-1] != "0" else "1")
    return "\n".join([
        "boot", "tick 4", *([_rx("i")] if scan else []),
        _rx(P.encode_image_write(0, image[:16])), _rx("PLY03"),
        _rx(P.encode_image_write(16, image[16:32])), _rx(bad),
        _rx(P.encode_image_write(56, image[56:72])), _rx("r001010"),
        _rx("k", 40), _rx("v", 14), _rx("PLY00"),
    ]) + "\n"


def cut_stimulus(robot: Robot) -> str:
    """The EEPROM as a cut after a write's header chunk leaves it (its first byte 0xFF:
    the simulators' harnesses cannot reset the MCU in the middle of a run), then the
    boot: image=bad, PLY03 and a commit refused; the header again and a commit: valid."""
    image = build_image(robot)
    return "\n".join([
        "poke 0 FF", "boot", "tick 4", _rx("v", 14), _rx("PLY03"), _rx("k", 10),
        _rx(P.encode_image_write(0, image[:16])), _rx("k", 40), _rx("v", 14), _rx("PLY00"),
    ]) + "\n"


def _rx(line: str, ticks: int = 8) -> str:
    """The line, then ticks enough for it to arrive, run and be answered at 9600 baud
    (the simulators send bytes at the line's rate; the Python core takes them at once)."""
    return f"rx {line}\\r\\n\ntick {ticks}"
