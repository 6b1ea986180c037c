"""What ``esair emulate`` does: generate (optionally), then serve or run the robot."""

from __future__ import annotations

import signal
import sys
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, TextIO

from esair_min.errors import EsairError
from esair_min.model.robot import Robot
from esair_min.emulator.faults import Faults
from esair_min.emulator.robot import Emulator


@dataclass
class EmulateOptions:
    pty: bool = False
    run_s: float | None = None
    sends: tuple[str, ...] = ()
    generate: Path | None = None
    scenario: str | None = None
    trace: Path | None = None
    faults: Faults = field(default_factory=Faults)
    speed: float = 1.0
    live: bool | None = None      # None: when stdout is a terminal


def generate_first(robot: Robot, out_dir: Path, log: Callable[[str], None]) -> bytes | None:
    """Generate the firmware (codegen) and the EEPROM image into ``out_dir``; return the
    image the emulated EEPROM is loaded with.

    The image is the generator's if it wrote exactly one ``*eeprom*.hex``; otherwise
    it is built here and written as ``<robot>-eeprom.hex`` next to the firmware."""
    try:
        from codegen import generate_robot  # type: ignore[attr-defined]
    except ImportError:
        raise EsairError("--generate needs the firmware generator (codegen.generate_robot), "
                         "which this installation does not have yet") from None
    out_dir = Path(out_dir)
    generate_robot(robot, out_dir)
    log(f"generated {robot.name} into {out_dir}")
    if robot.eeprom is None:
        return None
    from esair_min.core.image import build_image, read_hex, write_hex

    hexes = sorted(out_dir.rglob("*eeprom*.hex"))
    if len(hexes) != 1:
        hexes = [out_dir / f"{robot.name}-eeprom.hex"]
        write_hex(build_image(robot), hexes[0])
    log(f"EEPROM loaded from {hexes[0]}")
    return read_hex(hexes[0], robot.eeprom.size_bytes)


class _Stop:
    """Set by SIGINT/SIGTERM: the serving loop ends and the command exits 0."""

    def __init__(self) -> None:
        self.flag = False

    def __call__(self, signum=None, frame=None) -> None:
        self.flag = True

    def install(self) -> None:
        signal.signal(signal.SIGTERM, self)
        signal.signal(signal.SIGINT, self)


def emulate(robot: Robot, opts: EmulateOptions, out: TextIO | None = None,
            log: Callable[[str], None] | None = None) -> None:
    """Run ``esair emulate``: output (the pty path, or a headless run's lines) goes to
    ``out`` (standard output), messages to ``log`` (standard error)."""
    out = sys.stdout if out is None else out
    if log is None:
        def log(text: str) -> None:
            print(text, file=sys.stderr)
    if not opts.pty and opts.run_s is None:
        raise EsairError("give --pty to serve the robot on a pseudo-terminal, or --run "
                         "SECONDS to run it headless")
    if opts.pty and opts.run_s is not None:
        raise EsairError("--pty and --run exclude each other")
    if not opts.speed > 0:
        raise EsairError(f"--speed {opts.speed:g} must be more than 0")
    image = generate_first(robot, opts.generate, log) if opts.generate else None
    with ExitStack() as stack:
        trace = None
        if opts.trace is not None:
            from esair_min.emulator.tracefile import FileTraceWriter

            try:
                f = stack.enter_context(open(opts.trace, "w", encoding="ascii"))
            except OSError as exc:
                raise EsairError(f"cannot write the trace {opts.trace}: {exc.strerror}") from None
            trace = FileTraceWriter(f)
        emu = Emulator(robot, scenario=opts.scenario, faults=opts.faults, trace=trace,
                       eeprom_image=image)
        stack.callback(emu.close)
        if opts.pty:
            _serve(emu, opts, out)
        else:
            _run(emu, opts, out)


def _serve(emu: Emulator, opts: EmulateOptions, out: TextIO) -> None:
    from esair_min.emulator.ptyserver import serve_pty

    stop = _Stop()
    stop.install()
    live = out.isatty() if opts.live is None else opts.live
    view = None
    state: dict[str, str] = {}

    def on_path(path: str) -> None:
        state["path"] = path
        out.write(path + "\n")
        out.flush()

    with ExitStack() as stack:
        def on_idle() -> None:
            nonlocal view
            if not live or "path" not in state:
                return
            if view is None:
                from esair_min.emulator.liveview import LiveView

                view = stack.enter_context(LiveView(emu, state["path"]))
            view.poll()

        serve_pty(emu, on_path, lambda: stop.flag, opts.speed, on_idle)


def _run(emu: Emulator, opts: EmulateOptions, out: TextIO) -> None:
    """Headless: send the lines back to back once the robot is ready, run, print output."""
    assert opts.run_s is not None
    if opts.run_s < 0:
        raise EsairError(f"--run {opts.run_s:g} must be 0 or more seconds")
    emu.settle(max_s=1.0)          # boot: the image check and !READY
    if opts.sends:
        emu.write(b"".join(s.encode("latin-1") + b"\r\n" for s in opts.sends))
    emu.run_for(opts.run_s)
    data = emu.read()
    out.write(data.decode("latin-1").replace("\r\n", "\n"))
    out.flush()
