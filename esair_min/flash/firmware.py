"""The firmware a flash writes: a board's ``firmware.hex`` in the robot's build folder
(a PIC board's ``firmware-app.hex``, linked above ESAIR's bootloader), built first
(``esair build``'s steps) when it is missing or older than any board file."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from esair_min.flash import FlashError
from esair_min.model.robot import Robot


@dataclass(frozen=True)
class Firmware:
    role: str
    part: str
    clock_hz: int
    hex_path: Path
    built: bool                  # built now (missing or stale before)

    def image_bytes(self) -> int:
        """The bytes the .hex puts in flash."""
        total = 0
        for line in self.hex_path.read_text(encoding="latin-1").splitlines():
            if line.startswith(":") and len(line) >= 11 and line[7:9] == "00":
                total += int(line[1:3], 16)
        return total


def board_files(robot: Robot) -> list[Path]:
    """The files a robot's firmware is generated from (its board files)."""
    return [Path(f) for f in robot.files]


def stale(hex_path: Path, sources: list[Path]) -> bool:
    """True when ``hex_path`` is missing or older than one of ``sources``."""
    if not hex_path.exists():
        return True
    built = hex_path.stat().st_mtime
    return any(s.stat().st_mtime > built for s in sources)


def firmware(robot: Robot, build_dir: Path, role: str,
             build: bool = True) -> Firmware:
    """The ``role`` board's firmware, building the robot into ``build_dir`` when the .hex
    is missing or stale (and ``build``)."""
    board = robot.board(role)
    if board is None:
        roles = ", ".join(b.role for b in robot.boards)
        raise FlashError(f"robot '{robot.name}' has no board '{role}' (its boards: {roles})")
    # a PIC board is written through ESAIR's bootloader: the application linked above it
    pic = board.mcu.part == "pic18f452"
    hex_path = build_dir / role / ("firmware-app.hex" if pic else "firmware.hex")
    needed = stale(hex_path, board_files(robot))
    if needed and build:
        from esair_min.pic.build import build_robot

        build_robot(robot, build_dir, boot=pic)
    return Firmware(role, board.mcu.part, board.mcu.clock_hz, hex_path, needed and build)
