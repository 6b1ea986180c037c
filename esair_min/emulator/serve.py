"""What ``esair emulate`` does: generate (optionally), then serve or run the robot."""

from __future__ import annotations

import secrets
import signal
import sys
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, TextIO

from esair_min.errors import EsairError
from esair_min.model.robot import Robot
from esair_min.emulator.clock import NS_PER_S, seconds_to_ns
from esair_min.emulator.faults import Faults
from esair_min.emulator.robot import Emulator
from esair_min.model.identity import INSTANCE_RE


@dataclass
class EmulateOptions:
    pty: bool = False
    run_s: float | None = None
    sends: tuple[str, ...] = ()
    generate: Path | None = None
    scenario: str | None = None
    hold_scenario: bool = False   # with --pty: the scenario plays on SIGUSR1, not at boot
    trace: Path | None = None
    faults: Faults = field(default_factory=Faults)
    speed: float | None = None    # with --pty only; None: real time (1)
    live: bool | None = None      # None: when stdout is a terminal
    room: Path | None = None      # an omni-base robot's room (a YAML file); None: the default
    instance: str | None = None   # the v reply's instance; None: random with --pty
    pose: tuple[float, float, float] | None = None   # an omni-base robot's start (mm, mm, rad)
    world_out: Path | None = None  # an omni-base robot's true pose, to this datagram socket
    eeprom: Path | None = None    # the EEPROM's contents in this file (kept across runs)


def generate_first(robot: Robot, out_dir: Path, log: Callable[[str], None]) -> bytes | None:
    """Generate the firmware (codegen) and the EEPROM image into ``out_dir``; return the
    image the emulated EEPROM is loaded with.

    The image is the generator's if it wrote exactly one ``*eeprom*.hex``; otherwise
    it is built here and written as ``<robot>-eeprom.hex`` next to the firmware."""
    from esair_min.codegen import generate_robot
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


#: Exit status of a headless run stopped by Ctrl-C (128 + SIGINT, as shells report it).
INTERRUPTED = 130
#: A headless run advances in steps of this much virtual time, printing as it goes.
RUN_STEP_NS = 50_000_000


class _PlayOnSignal:
    """SIGUSR1 while serving: the scenario plays (again) from its start, at the server
    loop's next turn (the handler only sets a flag). The previous handler is put back by
    :meth:`restore`."""

    def __init__(self) -> None:
        self.flag = False
        self._old: object = None

    def __call__(self, signum=None, frame=None) -> None:
        self.flag = True

    def install(self) -> None:
        self._old = signal.signal(signal.SIGUSR1, self)

    def take(self, emu: Emulator) -> None:
        if self.flag:
            self.flag = False
            emu.play_scenario()

    def restore(self) -> None:
        signal.signal(signal.SIGUSR1, self._old)   # type: ignore[arg-type]


class _Stop:
    """Set by SIGINT/SIGTERM: the loop ends at its next step (the previous handlers are
    put back by :meth:`restore`)."""

    def __init__(self) -> None:
        self.flag = False
        self._old: dict[int, object] = {}

    def __call__(self, signum=None, frame=None) -> None:
        self.flag = True

    def install(self) -> None:
        for sig in (signal.SIGTERM, signal.SIGINT):
            self._old[sig] = signal.signal(sig, self)

    def restore(self) -> None:
        for sig, old in self._old.items():
            signal.signal(sig, old)   # type: ignore[arg-type]


def check_options(opts: EmulateOptions) -> None:
    """Refuse options that would be ignored, with the reason."""
    if not opts.pty and opts.run_s is None:
        raise EsairError("give --pty to serve the robot on a pseudo-terminal, or --run "
                         "SECONDS to run it headless")
    if opts.pty and opts.run_s is not None:
        raise EsairError("--pty and --run exclude each other")
    if opts.pty and opts.sends:
        raise EsairError("--send works with --run only; with --pty, send lines from another "
                         "terminal: esair send PORT LINE...")
    if opts.run_s is not None and opts.speed is not None:
        raise EsairError("--speed works with --pty only; --run runs as fast as the host can")
    if opts.hold_scenario and opts.scenario is None:
        raise EsairError("--hold-scenario needs --scenario: it holds that scenario until "
                         "SIGUSR1")
    if opts.hold_scenario and not opts.pty:
        raise EsairError("--hold-scenario works with --pty only; with --run the scenario "
                         "plays from boot")
    if opts.speed is not None and not opts.speed > 0:
        raise EsairError(f"--speed {opts.speed:g} must be more than 0")
    if opts.run_s is not None and opts.run_s < 0:
        raise EsairError(f"--run {opts.run_s:g} must be 0 or more seconds")
    if opts.instance is not None and not INSTANCE_RE.fullmatch(opts.instance):
        raise EsairError(f"--instance {opts.instance!r} must be 8 lowercase hex digits")


def emulate(robot: Robot, opts: EmulateOptions, out: TextIO | None = None,
            log: Callable[[str], None] | None = None) -> int:
    """Run ``esair emulate``: output (the pty path, or a headless run's lines) goes to
    ``out`` (standard output), messages to ``log`` (standard error). Returns the exit
    status: 0, or :data:`INTERRUPTED` when Ctrl-C stopped a headless run (what ran is
    kept: output printed, trace written)."""
    out = sys.stdout if out is None else out
    if log is None:
        def log(text: str) -> None:
            print(text, file=sys.stderr)
    check_options(opts)
    if robot.central.base is not None:
        from esair_min.emulator.starfish_serve import emulate_starfish

        return emulate_starfish(robot, opts, out, log, _serve_loop=_Stop, printer=_Printer)
    for flag, given in (("--room", opts.room), ("--pose", opts.pose),
                        ("--world-out", opts.world_out)):
        if given is not None:
            raise EsairError(f"{flag} is for a robot with an omni base (STARFISH); this robot "
                             "has none")
    image = generate_first(robot, opts.generate, log) if opts.generate else None
    with ExitStack() as stack:
        trace = None
        if opts.trace is not None:
            from esair_min.emulator.tracefile import FileTraceWriter

            try:
                # served in real time, the trace is written line by line (tail -f works)
                f = stack.enter_context(open(opts.trace, "w", encoding="ascii",
                                             buffering=1 if opts.pty else -1))
            except OSError as exc:
                raise EsairError(f"cannot write the trace {opts.trace}: {exc.strerror}") from None
            trace = FileTraceWriter(f)
        live = opts.pty and (out.isatty() if opts.live is None else opts.live)
        instance = opts.instance
        if instance is None and opts.pty:      # each boot on a pty is a robot of its own
            instance = secrets.token_hex(4)
        emu = Emulator(robot, scenario=opts.scenario, faults=opts.faults, trace=trace,
                       eeprom_image=image, transcript=live, instance=instance,
                       hold_scenario=opts.hold_scenario, eeprom_file=opts.eeprom)
        stack.callback(emu.close)
        if opts.pty:
            _serve(emu, opts, out)
            return 0
        return _run(emu, opts, out, log)


def _serve(emu: Emulator, opts: EmulateOptions, out: TextIO) -> None:
    from esair_min.emulator.ptyserver import PtyPort, serve_pty

    stop = _Stop()
    stop.install()
    play = _PlayOnSignal()
    play.install()                 # before the path is printed: a SIGUSR1 from then on counts
    live = out.isatty() if opts.live is None else opts.live
    view = None
    port = PtyPort()

    def on_path(path: str) -> None:
        out.write(path + "\n")
        out.flush()

    with ExitStack() as stack:
        def on_idle() -> None:
            nonlocal view
            play.take(emu)
            if not live:
                return
            if view is None:
                from esair_min.emulator.liveview import LiveView

                view = stack.enter_context(LiveView(emu, port))
            view.poll()

        try:
            serve_pty(emu, on_path, lambda: stop.flag, opts.speed or 1.0, on_idle, port)
        finally:
            stop.restore()
            play.restore()


def _run(emu: Emulator, opts: EmulateOptions, out: TextIO,
         log: Callable[[str], None]) -> int:
    """Headless: send the lines back to back once the robot is ready, run, print output
    as it comes. Ctrl-C (or SIGTERM) stops at the next step and keeps what ran."""
    assert opts.run_s is not None
    stop = _Stop()
    stop.install()
    try:
        emu.settle(max_s=1.0)          # boot: the image check and !READY
        if opts.sends:
            emu.write(b"".join(s.encode("latin-1") + b"\r\n" for s in opts.sends))
        start = emu.clock.now
        end = start + seconds_to_ns(opts.run_s)
        printer = _Printer(out)
        while not stop.flag:
            printer(emu.read())
            if emu.clock.now >= end:
                break
            emu.run_until(min(end, emu.clock.now + RUN_STEP_NS))
        printer(emu.read(), last=True)
    finally:
        stop.restore()
    if stop.flag:
        log(f"interrupted after {(emu.clock.now - start) / NS_PER_S:.3f} s of the "
            f"{opts.run_s:g} s run (virtual time): the output so far is printed"
            + (f" and the trace {opts.trace} is complete up to there" if opts.trace else ""))
        return INTERRUPTED
    return 0


class _Printer:
    """Writes what the robot sent, CR LF as newlines (a CR LF split between two reads
    included)."""

    def __init__(self, out: TextIO):
        self.out = out
        self.cr = False

    def __call__(self, data: bytes, last: bool = False) -> None:
        if self.cr:
            data = b"\r" + data
        self.cr = data.endswith(b"\r") and not last
        if self.cr:
            data = data[:-1]
        if data:
            self.out.write(data.decode("latin-1").replace("\r\n", "\n"))
            self.out.flush()
