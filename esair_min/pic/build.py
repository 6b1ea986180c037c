"""``esair build``: generate every board's firmware and build it for its MCU.

Each board folder's own Makefile does the build (``make -B pic18f452``, so every file is
compiled again and every warning is seen); any warning from sdcc, gpasm or gplink is a
failure. The footprint comes from the gplink map (:func:`esair_min.pic.toolchain.parse_map`).
A board with ``mcu.part: atmega328p`` is built by :mod:`esair_min.avr.build` instead
(``make -B atmega328p``, avr-gcc, the same rule on warnings).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace
from pathlib import Path

from esair_min.avr.build import AvrBuildError, AvrUsage
from esair_min.avr.build import build_board as build_avr_board
from esair_min.errors import EsairError
from esair_min.make import make_board
from esair_min.model import mcu
from esair_min.model.robot import Robot
from esair_min.pic.bootbuild import BootBuildError, BootUsage, build_boot, has_bootloader
from esair_min.pic.toolchain import MapUsage, Toolchain, ToolchainError, find_toolchain, parse_map

FLASH_BYTES = 32768      # PIC18F452 program memory
RAM_BYTES = 1536         # PIC18F452 data memory (general purpose)
# sdcc's stack bounds, also when `#pragma stack` puts it in a section not named "stack"
_STACK_RE = re.compile(r"^\s*_stack(_end)?\s+0x([0-9a-fA-F]+)\s+data\b", re.M)


class BuildError(EsairError):
    """The PIC toolchain is missing or a board's firmware did not build cleanly."""


@dataclass(frozen=True)
class BoardBuild:
    role: str
    folder: Path
    usage: MapUsage | AvrUsage
    part: str = "pic18f452"
    boot: BootUsage | None = None     # ESAIR's bootloader and the application above it

    @property
    def flash_bytes(self) -> int:
        """The part's program memory (esair_min.model.mcu)."""
        return mcu.MCUS[self.part].flash_bytes

    @property
    def ram_bytes(self) -> int:
        """The part's data memory (esair_min.model.mcu)."""
        return mcu.MCUS[self.part].ram_bytes

    @property
    def hex(self) -> Path:
        return self.folder / "firmware.hex"

    @property
    def cod(self) -> Path:
        """The symbol file gpsim loads."""
        return self.folder / "build-pic" / "firmware.cod"


def toolchain() -> Toolchain:
    """The installed toolchain, or BuildError saying how to install it."""
    try:
        return find_toolchain()
    except ToolchainError as exc:
        raise BuildError(str(exc)) from None


def build_board(folder: Path, tc: Toolchain, timeout: float = 300.0,
                make_vars: tuple[str, ...] = ()) -> MapUsage:
    """``make -B pic18f452`` in one generated board folder; the map's usage.
    ``make_vars``: extra ``NAME=value`` arguments of make.

    Raises BuildError when make fails or any tool prints a warning (the lines shown)."""
    make_board(folder, "pic18f452", "PIC", BuildError, (f"PREFIX={tc.prefix}", *make_vars),
               timeout)
    map_path = folder / "firmware.map"
    if not map_path.exists():
        raise BuildError(f"{folder}: make pic18f452 wrote no firmware.map")
    try:
        usage = parse_map(map_path)
    except ToolchainError as exc:
        raise BuildError(str(exc)) from None
    bounds = {end: int(addr, 16) for end, addr in _STACK_RE.findall(map_path.read_text())}
    if usage.stack_bytes == 0 and "" in bounds and "_end" in bounds:
        usage = replace(usage, stack_bytes=bounds["_end"] - bounds[""] + 1)
    return usage


def build_robot(robot: Robot, out_dir: Path, tc: Toolchain | None = None,
                boot: bool = False) -> list[BoardBuild]:
    """Generate every board of ``robot`` under ``out_dir`` and build each for the PIC;
    with ``boot`` also each PIC board's bootloader and the application linked above it
    (``firmware-app.hex``, esair_min.pic.bootbuild), where the board has one."""
    from esair_min.codegen import generate_robot

    parts: dict[str, str] = {b.role: b.mcu.part for b in robot.boards}
    if tc is None and "pic18f452" in parts.values():
        tc = toolchain()
    result = generate_robot(robot, Path(out_dir))
    no_port = [role for role in result.boards
               if not (Path(out_dir) / role / "ports" / parts[role]).is_dir()]
    if no_port:
        raise BuildError(f"robot '{robot.name}': no port yet for "
                         + ", ".join(f"{role} on the {parts[role]}" for role in no_port)
                         + " (their C runs on the host: make host in each board's folder; "
                         "docs/firmware.md)")
    builds = []
    for role in result.boards:
        folder = Path(out_dir) / role
        if parts[role] == "atmega328p":
            try:
                usage: MapUsage | AvrUsage = build_avr_board(folder)
            except AvrBuildError as exc:
                raise BuildError(str(exc)) from None
        else:
            assert tc is not None
            usage = build_board(folder, tc)
        boot_usage = None
        if boot and parts[role] == "pic18f452" and has_bootloader(folder):
            assert tc is not None
            try:
                boot_usage = build_boot(folder, tc, robot.name, role)
            except BootBuildError as exc:
                raise BuildError(str(exc)) from None
        builds.append(BoardBuild(role, folder, usage, parts[role], boot_usage))
    return builds


def summary_lines(builds: list[BoardBuild]) -> list[str]:
    """The footprint table ``esair build`` prints. A PIC18F452's RAM includes its software
    stack (SDCC reserves it); an ATmega328P's stack grows at run time on top of the static
    RAM shown (``+ stack``), so with such a board the column is plain ``RAM``."""
    avr = any(b.part == "atmega328p" for b in builds)
    rows = [("board", "program memory", "RAM" if avr else "RAM (with stack)", "stack")
            + (("mcu",) if avr else ())]
    for b in builds:
        u = b.usage
        flash, ram = b.flash_bytes, b.ram_bytes
        rows.append((b.role,
                     f"{u.program_bytes} B of {flash} ({u.program_bytes / flash:.1%})",
                     f"{u.data_bytes} B of {ram} ({u.data_bytes / ram:.1%})"
                     + (" + stack" if b.part == "atmega328p" else ""),
                     f"{u.stack_bytes} B" if b.part == "pic18f452" else "-")
                    + ((b.part,) if avr else ()))
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    return (["  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip()
             for r in rows] + [b.boot.line(b.role) for b in builds if b.boot is not None])
