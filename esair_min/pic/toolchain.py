"""Locate and drive the PIC18F452 toolchain (SDCC pic16, gputils, gpsim).

The toolchain is installed by ``scripts/install-toolchain.sh`` into
``$ESAIR_TOOLCHAIN`` (default ``/opt/esair-toolchain``); see docs/toolchain.md.
Stdlib only; nothing here runs at import time.
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

DEFAULT_PREFIX = "/opt/esair-toolchain"
INSTALL_HINT = "run scripts/install-toolchain.sh (as root) to install it"
SFR_START = 0xF80          # access-bank SFRs: not counted as RAM use
CONFIG_START = 0x200000    # ID locations, config words: not counted as program
_NOISE = ("attempt write to invalid", "    address 0x")


class ToolchainError(Exception):
    """The PIC toolchain is missing, broken, or a tool run failed."""


@dataclass(frozen=True)
class Toolchain:
    prefix: Path
    sdcc: Path
    gplink: Path
    gpsim: Path
    include_dir: Path   # holds esair/p18f452_regs.h; pass as -I
    lib_dir: Path       # holds libdev18f452.lib; pass as -L


@dataclass(frozen=True)
class MapUsage:
    program_bytes: int    # code + const data, config words excluded
    data_bytes: int       # RAM: globals, sdcc's scratch registers and the software stack
    stack_bytes: int      # the software stack's share of data_bytes
    program_addresses_used: int  # gplink's own count (includes config bytes)


def find_toolchain(prefix: str | os.PathLike[str] | None = None) -> Toolchain:
    """Return the installed toolchain, or raise ToolchainError saying how to install it."""
    root = Path(prefix or os.environ.get("ESAIR_TOOLCHAIN") or DEFAULT_PREFIX)
    sdcc = root / "bin" / "sdcc"
    inc = root / "include"
    lib = root / "lib" / "esair"
    missing = [str(p) for p in (sdcc, inc / "esair" / "p18f452_regs.h", lib / "libdev18f452.lib")
               if not p.exists()]
    tools = {name: shutil.which(name) for name in ("gplink", "gpsim")}
    missing += [name for name, path in tools.items() if path is None]
    gplink, gpsim = tools["gplink"], tools["gpsim"]
    if missing or gplink is None or gpsim is None:
        raise ToolchainError(f"PIC18F452 toolchain not found in {root} "
                             f"(missing: {', '.join(missing)}); {INSTALL_HINT}")
    return Toolchain(prefix=root, sdcc=sdcc, gplink=Path(gplink),
                     gpsim=Path(gpsim), include_dir=inc, lib_dir=lib)


def sdcc_flags(tc: Toolchain, *, link: bool = False) -> list[str]:
    """sdcc flags for the PIC18F452: compile (``-c`` not included) or link (map file on)."""
    flags = ["-mpic16", "-p18f452", "--no-warn-non-free", "-Wa,-w1"]
    if link:
        return flags + [f"-L{tc.lib_dir}", "-Wl,-m"]
    return flags + [f"-I{tc.include_dir}"]


def compile_and_link(tc: Toolchain, sources: list[Path], workdir: Path,
                     name: str = "fw", timeout: float = 120.0) -> Path:
    """Compile C sources and link them into ``workdir/name.hex`` (+ .cod, .map).

    Returns the .hex path; raises ToolchainError with sdcc's output on failure.
    """
    workdir.mkdir(parents=True, exist_ok=True)
    objs = []
    for src in sources:
        obj = workdir / (Path(src).stem + ".o")
        _run([str(tc.sdcc), *sdcc_flags(tc), "-c", str(Path(src).resolve()), "-o", obj.name],
             workdir, timeout)
        objs.append(obj.name)
    _run([str(tc.sdcc), *sdcc_flags(tc, link=True), *objs, "-o", f"{name}.hex"], workdir, timeout)
    return workdir / f"{name}.hex"


def _run(cmd: list[str], cwd: Path, timeout: float) -> str:
    try:
        proc = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired as exc:
        raise ToolchainError(f"{Path(cmd[0]).name} timed out after {timeout} s") from exc
    if proc.returncode != 0:
        raise ToolchainError(f"{' '.join(cmd)} failed ({proc.returncode}):\n"
                             f"{proc.stdout}{proc.stderr}".rstrip())
    return proc.stdout + proc.stderr


_SECTION_RE = re.compile(r"^\s*(\S+)\s+(\w+)\s+0x([0-9a-fA-F]+)\s+(program|data)\s+0x([0-9a-fA-F]+)\s*$")
_USED_RE = re.compile(r"^\s*(\d+) program addresses used", re.M)


def _union_size(spans: list[tuple[int, int]]) -> int:
    total, end = 0, -1
    for start, stop in sorted(spans):
        if stop > end:
            total += stop - max(start, end)
            end = stop
    return total


def parse_map(path: str | os.PathLike[str]) -> MapUsage:
    """Program and RAM bytes used, from a gplink map file (``sdcc ... -Wl,-m``).

    Both come from the "Section Info" table (overlapping sections counted once):
    program = sections in program memory below the config area; data = sections
    in data memory below the SFRs (0xF80), which includes sdcc's
    ``stack_section`` (the software stack, 256 B by default).
    """
    text = Path(path).read_text(errors="replace")
    prog: list[tuple[int, int]] = []
    data: list[tuple[int, int]] = []
    stack = 0
    for line in text.splitlines():
        m = _SECTION_RE.match(line)
        if not m:
            continue
        name, _kind, addr, where, size = m.groups()
        start, n = int(addr, 16), int(size, 16)
        if where == "program" and start < CONFIG_START:
            prog.append((start, start + n))
        elif where == "data" and start < SFR_START:
            data.append((start, start + n))
            if name == "stack_section" or name.startswith("stack"):
                stack += n
    used = _USED_RE.search(text)
    if used is None or not prog:
        raise ToolchainError(f"{path}: not a gplink map file (no section table or "
                             "'program addresses used' line)")
    return MapUsage(program_bytes=_union_size(prog), data_bytes=_union_size(data),
                    stack_bytes=stack, program_addresses_used=int(used.group(1)))


def filter_gpsim_output(text: str) -> str:
    """Drop gpsim's per-address "attempt write to invalid register" warnings."""
    return "".join(line for line in text.splitlines(keepends=True)
                   if not line.startswith(_NOISE))


def run_gpsim(script_text: str, workdir: str | os.PathLike[str], timeout: float = 60.0,
              tc: Toolchain | None = None, script_name: str = "bench.stc") -> str:
    """Run ``gpsim -i -c <script>`` headless in ``workdir``; return filtered stdout+stderr.

    The script should end with ``quit`` (one is appended if missing) and bound the
    run itself (e.g. ``break c N`` before ``run``); ``timeout`` (wall seconds) is a
    backstop that raises ToolchainError.
    """
    tc = tc or find_toolchain()
    work = Path(workdir)
    work.mkdir(parents=True, exist_ok=True)
    if not re.search(r"^\s*quit\s*$", script_text, re.M):
        script_text = script_text.rstrip("\n") + "\nquit\n"
    (work / script_name).write_text(script_text)
    try:
        proc = subprocess.run([str(tc.gpsim), "-i", "-c", script_name], cwd=work,
                              stdin=subprocess.DEVNULL, capture_output=True, timeout=timeout)
    except subprocess.TimeoutExpired as exc:
        raise ToolchainError(f"gpsim timed out after {timeout} s running {work / script_name}") from exc
    out = filter_gpsim_output((proc.stdout + proc.stderr).decode("latin-1"))
    if proc.returncode != 0:
        raise ToolchainError(f"gpsim exited with {proc.returncode}:\n{out[-2000:]}")
    return out
