"""What ``esair emulate`` does: generate (optionally), then serve or run the robot.

One path for every robot: the options checked, the firmware generated, the trace file
opened, then the robot served on a pty or run headless. What differs between robots
(their boards, the options they refuse, their view and closing line) is each robot's
``launch`` module (:mod:`.papaman.launch`, :mod:`.starfish.launch`), a :class:`RobotRun`.
"""

from __future__ import annotations

import secrets
import signal
import sys
from contextlib import AbstractContextManager, ExitStack
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Protocol, TextIO

from esair_min import sigs
from esair_min.errors import EsairError
from esair_min.model.robot import Robot
from esair_min.emulator.clock import NS_PER_S, seconds_to_ns
from esair_min.emulator.faults import Faults
from esair_min.emulator.line import SerialHost
from esair_min.model.identity import INSTANCE_RE

if TYPE_CHECKING:  # pragma: no cover
    from esair_min.emulator.ptyserver import PtyPort


@dataclass
class EmulateOptions:
    pty: bool = False
    run_s: float | None = None
    sends: tuple[str, ...] = ()
    generate: Path | None = None
    scenario: str | None = None
    hold_scenario: bool = False   # with --pty: the scenario plays on SIGUSR1, not at boot
    trace: Path | None = None
    trace_rx: bool = False        # the trace also holds the lines the robot received
    faults: Faults = field(default_factory=Faults)
    speed: float | None = None    # with --pty only; None: real time (1)
    live: bool | None = None      # None: when stdout is a terminal
    room: Path | None = None      # an omni-base robot's room (a YAML file); None: the default
    instance: str | None = None   # the v reply's instance; None: random with --pty
    pose: tuple[float, float, float] | None = None   # an omni-base robot's start (mm, mm, rad)
    world_out: Path | None = None  # an omni-base robot's true pose, to this datagram socket
    eeprom: Path | None = None    # the EEPROM's contents in this file (kept across runs)
    strict_baud: bool = False     # with --pty: bytes at another baud than the robot's garbled


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


class _Stop:
    """Set by SIGINT/SIGTERM: the loop ends at its next step (the previous handlers are
    put back by :meth:`restore`)."""

    def __init__(self) -> None:
        self.flag = False
        self._old: dict[int, object] = {}

    def __call__(self, _signum=None, _frame=None) -> None:
        self.flag = True

    def install(self) -> None:
        for sig in (signal.SIGTERM, signal.SIGINT):
            if not sigs.ignored(sig):           # a background job keeps its ignore
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
    if opts.strict_baud and not opts.pty:
        raise EsairError("--strict-baud works with --pty only (a port's baud setting)")
    if opts.speed is not None and not opts.speed > 0:
        raise EsairError(f"--speed {opts.speed:g} must be more than 0")
    if opts.run_s is not None and opts.run_s < 0:
        raise EsairError(f"--run {opts.run_s:g} must be 0 or more seconds")
    if opts.instance is not None and not INSTANCE_RE.fullmatch(opts.instance):
        raise EsairError(f"--instance {opts.instance!r} must be 8 lowercase hex digits")


class RobotRun(Protocol):
    """One robot's part of ``esair emulate`` (a robot's ``launch`` module makes it): the
    emulated boards, what its serve loop adds at each turn, and its closing line."""

    #: a headless ``--run S`` ends S seconds after boot (True) or after settling (False)
    run_from_boot: bool

    def __init__(self, robot: Robot, opts: EmulateOptions, stack: ExitStack,
                 image: bytes | None, trace: TextIO | None, instance: str | None,
                 live: bool) -> None:
        """The boards, closed by ``stack``; ``trace`` open for writing, or None."""

    @staticmethod
    def refuse(opts: EmulateOptions) -> None:
        """Raise for options this robot would ignore."""

    @property
    def sim(self) -> SerialHost:
        """What serve_pty and a headless run drive."""
        ...

    def install(self) -> None:
        """Signal handlers of this robot while served (before the path is printed)."""

    def restore(self) -> None:
        """Put back what :meth:`install` replaced."""

    def idle(self) -> None:
        """One turn of the serve loop (the trace written, a side channel fed)."""

    def view(self, port: PtyPort, out: TextIO) -> AbstractContextManager[Any]:
        """The live terminal view (``poll()`` repaints it)."""
        ...

    def flush(self) -> None:
        """Write what the trace holds so far."""

    def closing(self) -> str | None:
        """The line for standard error when the run ends (None: none)."""
        ...


def _robot_class(robot: Robot) -> type[RobotRun]:
    """The robot's own part: STARFISH's when its central board drives an omni base,
    PAPA-MAN's (servo and sensor boards) otherwise."""
    if robot.central.base is not None:
        from esair_min.emulator.starfish.launch import StarfishRun

        return StarfishRun
    from esair_min.emulator.papaman.launch import PapamanRun

    return PapamanRun


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
    robot_run = _robot_class(robot)
    robot_run.refuse(opts)
    image = generate_first(robot, opts.generate, log) if opts.generate else None
    with ExitStack() as stack:
        trace = None
        if opts.trace is not None:
            try:
                # served in real time, the trace is written line by line (tail -f works)
                trace = stack.enter_context(open(opts.trace, "w", encoding="ascii",
                                                 buffering=1 if opts.pty else -1))
            except OSError as exc:
                raise EsairError(f"cannot write the trace {opts.trace}: {exc.strerror}") from None
        elif opts.trace_rx:
            raise EsairError("--trace-rx adds to the trace: give --trace FILE too")
        instance = opts.instance
        if instance is None and opts.pty:      # each boot on a pty is a robot of its own
            instance = secrets.token_hex(4)
        live = opts.pty and (out.isatty() if opts.live is None else opts.live)
        run = robot_run(robot, opts, stack, image=image, trace=trace, instance=instance,
                        live=live)
        if opts.pty:
            uart = robot.central.uart
            _serve(run, opts, out, uart.baud if opts.strict_baud and uart else None)
            return 0
        return _run(run, opts, out, log)


def _serve(run: RobotRun, opts: EmulateOptions, out: TextIO, baud: int | None) -> None:
    from esair_min.emulator.ptyserver import PtyPort, serve_pty

    stop = _Stop()
    stop.install()
    run.install()                  # before the path is printed: a signal from then on counts
    live = out.isatty() if opts.live is None else opts.live
    view = None
    port = PtyPort()

    def on_path(path: str) -> None:
        out.write(path + "\n")
        out.flush()

    with ExitStack() as stack:
        def on_idle() -> None:
            nonlocal view
            run.idle()
            if not live:
                return
            if view is None:       # after the path is printed
                view = stack.enter_context(run.view(port, out))
            view.poll()

        try:
            serve_pty(run.sim, on_path, lambda: stop.flag, opts.speed or 1.0, on_idle, port,
                      baud)
        finally:
            stop.restore()
            run.restore()


def _run(run: RobotRun, opts: EmulateOptions, out: TextIO,
         log: Callable[[str], None]) -> int:
    """Headless: send the lines back to back once the robot is ready, run, print output
    as it comes. Ctrl-C (or SIGTERM) stops at the next step and keeps what ran."""
    assert opts.run_s is not None
    sim = run.sim
    stop = _Stop()
    stop.install()
    try:
        sim.settle(max_s=1.0)          # boot: the image check and !READY
        if opts.sends:
            sim.write(b"".join(s.encode("latin-1") + b"\r\n" for s in opts.sends))
        start = sim.clock.now
        end = (0 if run.run_from_boot else start) + seconds_to_ns(opts.run_s)
        printer = _Printer(out)
        while not stop.flag:
            printer(sim.read())
            if sim.clock.now >= end:
                break
            sim.run_until(min(end, sim.clock.now + RUN_STEP_NS))
            run.flush()
        printer(sim.read(), last=True)
        run.flush()
    finally:
        stop.restore()
    if stop.flag:
        log(f"interrupted after {(sim.clock.now - start) / NS_PER_S:.3f} s of the "
            f"{opts.run_s:g} s run (virtual time): the output so far is printed"
            + (f" and the trace {opts.trace} is complete up to there" if opts.trace else ""))
    closing = run.closing()
    if closing is not None:
        log(closing)
    return INTERRUPTED if stop.flag else 0


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
