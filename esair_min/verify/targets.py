"""The four targets of ``esair verify`` and one run of a stimulus script on each.

- ``python``: the Python core (esair_min.core.stimulus), run line by line so each trace
  event is known to come from one script line (the command that led to it);
- ``host``: the generated C core built for the host (``make host``), the same script;
- ``pic``: the central board built with SDCC, run in gpsim (esair_min.pic.gpsim_harness);
- ``avr``: the central board built with avr-gcc, run in simavr (esair_min.avr.simavr_harness).

A robot's MCUs allow python and host always, and the simulator of its central board's
part. :func:`build` makes the firmware once (every board for its chip: the flash and RAM
budgets need them all); the runs reuse it.
"""

from __future__ import annotations

import subprocess
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from esair_min.core.stimulus import Rig, run_line
from esair_min.core.script import LineError, line_text, script_lines
from esair_min.core.trace import without_marks
from esair_min.errors import EsairError, Mark, ProtocolError
from esair_min.model.robot import Robot

TARGETS = ("python", "host", "pic", "avr")
CHIP_TARGET = {"pic18f452": "pic", "atmega328p": "avr"}


class VerifyError(EsairError):
    """A target cannot run (its toolchain is missing, a build failed, a bad script)."""


def allowed_targets(robot: Robot) -> tuple[str, ...]:
    """The targets the robot's central board allows: the Python core, the host C, the
    simulator of its part."""
    chip = CHIP_TARGET.get(robot.central.mcu.part)
    return ("python", "host") + ((chip,) if chip else ())


def choose_targets(robot: Robot, asked: str | None) -> tuple[str, ...]:
    """``--targets`` (comma-separated) checked against what the robot allows; None: all."""
    allowed = allowed_targets(robot)
    if asked is None:
        return allowed
    names = tuple(dict.fromkeys(t.strip() for t in asked.split(",") if t.strip()))
    for t in names:
        if t not in TARGETS:
            raise VerifyError(f"unknown target '{t}' (python, host, pic, avr)")
        if t not in allowed:
            raise VerifyError(f"target '{t}' needs a central board on the "
                              f"{'PIC18F452' if t == 'pic' else 'ATmega328P'}; "
                              f"'{robot.name}' runs on {robot.central.mcu.part} "
                              f"(its targets: {', '.join(allowed)})")
    if "python" not in names:
        names = ("python",) + names        # the reference every target is compared with
    return names


@dataclass
class Firmware:
    """The robot's generated firmware in ``folder`` (one sub-folder per board): the host
    binary of the central board and each board's chip build."""

    folder: Path
    host: Path | None = None
    builds: dict[str, Any] = field(default_factory=dict)    # role -> BoardBuild

    @property
    def central(self) -> Path:
        return self.folder / "central"


def build_host(central: Path) -> Path:
    """``make host`` in a generated central board folder (gcc, warnings are errors)."""
    proc = subprocess.run(["make", "-s", "--no-print-directory", "host"], cwd=central,
                          capture_output=True, text=True, timeout=300)
    if proc.returncode != 0:
        raise VerifyError(f"{central}: make host failed:\n{(proc.stdout + proc.stderr)[-2000:]}")
    return central / "firmware_host"


def build(robot: Robot, targets: tuple[str, ...], folder: Path) -> Firmware:
    """Generate the firmware into ``folder``; build the host port and, for a chip target,
    every board for its chip."""
    from esair_min.codegen import generate_robot
    from esair_min.pic.build import BuildError, build_robot

    fw = Firmware(Path(folder))
    if any(t in targets for t in ("pic", "avr")):
        try:
            fw.builds = {b.role: b for b in build_robot(robot, fw.folder)}
        except BuildError as exc:
            raise VerifyError(str(exc)) from None
    else:
        generate_robot(robot, fw.folder)
    if "host" in targets:
        fw.host = build_host(fw.central)
    return fw


def prepare(robot: Robot, targets: tuple[str, ...], text: str, script_name: str | None,
            work: Path, say: Callable[[str], None],
            firmware: Firmware | None) -> tuple[Path, Firmware | None]:
    """The scenario's file and the firmware the targets run: ``text`` written into
    ``work`` (the file named ``script_name`` instead, where it is one: the builder's own,
    named in errors, its folder the one its `image` lines are read from), and the
    firmware built there unless given."""
    work.mkdir(parents=True, exist_ok=True)
    path = work / "scenario.txt"
    path.write_text(text)
    if script_name and Path(script_name).is_file():
        path = Path(script_name)
    if firmware is None and any(t != "python" for t in targets):
        t0 = time.monotonic()
        firmware = build(robot, targets, work / "firmware")
        say(f"build: {', '.join(t for t in targets if t != 'python')} firmware in "
            f"{time.monotonic() - t0:.1f} s")
    return path, firmware


@dataclass
class TargetRun:
    """One target's run: its trace (docs/trace-format.md lines, ``@`` marks removed) and
    what its simulator recorded (``sim``: GpsimRun / AvrRun)."""

    target: str
    trace: list[str]
    seconds: float = 0.0
    sim: Any = None
    causes: list[int] = field(default_factory=list)     # python: script line of each event


def run_python(robot: Robot, script: str, path: str = "<scenario>") -> TargetRun:
    """The Python core over ``script``, each trace line's script line number kept."""
    rig = Rig(robot)
    base = path[:path.rfind("/") + 1]
    causes: list[int] = []
    for number, raw in script_lines(script.encode("utf-8")):
        try:
            run_line(rig, line_text(raw), base)
        except LineError as exc:
            raise ProtocolError(exc.message, Mark(path, number, exc.column)) from None
        except EsairError as exc:
            raise ProtocolError(exc.message, Mark(path, number, 1)) from None
        causes += [number] * (len(rig.writer.lines) - len(causes))
    rig.writer.close()
    causes += [0] * (len(rig.writer.lines) - len(causes))
    keep = [i for i, line in enumerate(rig.writer.lines) if not line.startswith("@ ")]
    return TargetRun("python", [rig.writer.lines[i] for i in keep],
                     causes=[causes[i] for i in keep])


def run_host(binary: Path, script_path: Path) -> TargetRun:
    proc = subprocess.run([str(binary), str(script_path)], capture_output=True, text=True,
                          timeout=300)
    if proc.returncode != 0:
        raise VerifyError(f"the host build stopped: {proc.stderr.strip()[-2000:]}")
    return TargetRun("host", without_marks(proc.stdout))


def run_pic(robot: Robot, script: str, fw: Firmware, work: Path,
            epilogue: tuple[str, ...] = (), prologue: tuple[str, ...] = ()) -> TargetRun:
    from esair_min.pic.gpsim_harness import run_stimulus
    from esair_min.pic.toolchain import ToolchainError

    try:
        run = run_stimulus(robot, script, fw.builds["central"].cod, work, timeout=600,
                           prologue=prologue, epilogue=epilogue)
    except ToolchainError as exc:
        raise VerifyError(f"gpsim: {exc}") from None
    return TargetRun("pic", without_marks(run.trace()), sim=run)


def avr_watch(elf: Path) -> tuple[int, ...]:
    """The byte addresses of ``hal_uart_rx``, ``hal_watchdog_clear`` (called first in
    every superloop pass) and ``core_rx_end`` (a line end): the decoder's timing."""
    from esair_min.avr.simavr_harness import symbol

    return tuple(symbol(elf, name) for name in ("hal_uart_rx", "hal_watchdog_clear",
                                                "core_rx_end"))


def run_avr(robot: Robot, script: str, fw: Firmware, work: Path) -> TargetRun:
    from esair_min.avr.simavr_harness import run_stimulus

    elf = fw.builds["central"].folder / "firmware.elf"
    run = run_stimulus(robot, script, elf, work, isrs=True)
    return TargetRun("avr", without_marks(run.trace()), sim=run)
