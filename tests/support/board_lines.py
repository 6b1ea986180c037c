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
