"""``esair std run``: deploy a robot and keep it running (or ``--run SECONDS``, headless,
then a summary)."""

from __future__ import annotations

import os
import signal
import sys
import threading
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from esair_min import sigs
from esair_min.cli.pipes import friendly

from ..errors import ControlError, TransportError
from ..transport.codec import JSONObject

if TYPE_CHECKING:  # pragma: no cover
    from esair_min.config.yamlload import Document

    from ..deploy.model import Deployment
    from ..lean.plain import PlainDeployment
    from ..runtime import Runtime
from ..endpoint import reaches_beyond
from .shared_options import endpoint_option, exposure, insecure_option
from .table import table as _table


def _load(path: str | Path, port: str | None,
          emulate: dict[str, str]) -> Deployment | PlainDeployment:
    """The deployment, through the one loader ``esair std check`` uses, with the command
    line's ``--port`` / ``--trace`` / ``--scenario`` applied to the document first.
    Checked in a short-lived child (or taken from the cache) and loaded as plain data
    when it can be (esair_std/lean/): this process, the robot side, then never imports
    pydantic; else (a problem to report, a security section) checked here."""
    def edit(doc: Document) -> None:
        from ..deploy.overrides import set_emulate, set_port
        if port is not None:
            set_port(doc, port)
        if emulate:
            set_emulate(doc, emulate)

    from ..lean.checked import checked_deployment
    plain = checked_deployment(path, {"port": port, "emulate": emulate}, edit)
    if plain is not None:
        return plain
    from ..deploy import load_document
    return load_document(path, edit=edit)[0]


class _Local:
    """The runtime seen through the control client's one method (for the live table)."""

    def __init__(self, rt: Runtime):
        self.rt = rt
        self.robot = rt.robot

    def call(self, verb: str, body: JSONObject | None = None) -> Any:      # as the client's
        if verb == "ls":
            from ..control.listing import components
            return components(self.rt) if (body or {}).get("all") else self.rt.ls()
        return self.rt.inspect(str((body or {})["name"]))


def _live(rt: Runtime, stop: threading.Event, seconds: float | None) -> None:
    from rich.live import Live

    from .top import render, snapshot
    local = _Local(rt)
    before: dict[str, tuple[float, int]] = {}
    end = None if seconds is None else time.monotonic() + seconds
    with Live(render(snapshot(local), before, rt.robot), auto_refresh=False) as live:
        while not stop.wait(1.0):
            live.update(render(snapshot(local), before, rt.robot), refresh=True)
            if end is not None and time.monotonic() >= end:
                break


SUMMARY_COLS = ["name", "kind", "state", "samples", "overwritten", "commands", "puts_ok",
                "puts_failed", "restarts"]


#: Exit status after Ctrl-C (128 + SIGINT), as shells report it.
INTERRUPTED = 130


@click.command("run")
@click.argument("deployment", metavar="FILE")
@click.option("--mode", type=click.Choice(["thread", "process"]), default=None,
              help="Override the file's mode.")
@click.option("--run", "seconds", type=click.FloatRange(min=0), default=None,
              metavar="SECONDS", help="Run headless this long, then print a summary and stop.")
@endpoint_option("Control endpoint to listen on (default: $ESAIR_STD_ENDPOINT, else the "
                 "file's).")
@click.option("--no-control", is_flag=True,
              help="Thread mode: open no control endpoint (no network at all).")
@click.option("--port", default=None, metavar="DEVICE",
              help="Set the `port` option of every resource that has one (a serial device, "
                   "a pty, an esair:// URL), e.g. the real robot's /dev/ttyUSB0; an error "
                   "when none has one.")
@click.option("--trace", default=None, metavar="FILE", type=click.Path(dir_okay=False),
              help="The emulated robot (port: emulate) writes its event trace to FILE.")
@click.option("--scenario", default=None, metavar="NAME|FILE",
              help="The emulated robot's sensor readings over time (a file, or a name in "
                   "the robot's scenarios/).")
@click.option("--top/--no-top", "top", default=None,
              help="Show the live table of `esair std top` while running (default: when "
                   "the output is a terminal and --run is not given).")
@click.option("--join", "join", multiple=True, metavar="tcp/HOST:PORT",
              help="Another robot's control endpoint to join (repeat): behaviors then put "
                   "to and get from its behaviors as ROBOT/NAME.")
@click.option("--hmi", "hmi", is_flag=True,
              help="Also serve the remote control center in a browser (`esair std hmi`, "
                   "docs/hmi.md) and print its URL.")
@click.option("--hmi-listen", default="127.0.0.1:8080", show_default=True,
              metavar="HOST:PORT", help="Where --hmi serves the page.")
@click.option("--foxglove", "foxglove", is_flag=True,
              help="Also serve the robot live to Foxglove / Lichtblick (`esair std foxglove`, "
                   "docs/foxglove.md) and print its ws:// URL.")
@click.option("--foxglove-listen", default="127.0.0.1:8765", show_default=True,
              metavar="HOST:PORT", help="Where --foxglove listens.")
@click.option("--stopped", is_flag=True,
              help="Start latched in the STOPPED state: no actuator command is taken until "
                   "`esair std release` (docs/std.md, \"The latched stop\").")
@insecure_option()
@friendly
def run_cmd(deployment: str, mode: str | None, seconds: float | None, endpoint: str | None,
            no_control: bool, port: str | None, trace: str | None, scenario: str | None,
            top: bool | None, join: tuple[str, ...], hmi: bool, hmi_listen: str,
            foxglove: bool, foxglove_listen: str, stopped: bool, insecure: bool) -> None:
    """Deploy FILE (a deployment file, or a bundled example such as `lab`) and run it
    until Ctrl-C (exit status 130), or for --run SECONDS (exit status 1, naming them,
    when components are failed at the end). Other terminals control it
    with `esair std ls`, `add`, `remove`, `put`, ... over the control endpoint."""
    from ..deploy.bundled import resolve_deployment
    from ..runtime import Runtime

    emulate = {}
    if trace is not None:
        emulate["trace"] = os.path.abspath(trace)
    if scenario is not None:
        emulate["scenario"] = (os.path.abspath(scenario) if os.path.exists(scenario)
                               else scenario)
    if emulate and port not in (None, "emulate"):
        raise click.UsageError(f"--{next(iter(emulate))} is for the emulated robot, not "
                               f"--port {port}")
    dep = _load(resolve_deployment(deployment), port, emulate)
    rt = Runtime(dep, mode=mode, endpoint=endpoint,
                 control=None if not no_control else False, join=list(join),
                 settle_heap=True,        # this process is the runtime's (heap.py)
                 stopped=stopped)
    if rt.mode_name == "thread" and not no_control:
        rt.control = True
    if (hmi or foxglove) and not rt.control:
        raise ControlError(f"--{'hmi' if hmi else 'foxglove'} needs the control endpoint "
                           "(drop --no-control)")
    if rt.control and reaches_beyond(rt.endpoint) and not _secured(rt):
        exposure(f"listening on {rt.endpoint}", "TLS client certificates (a tls/ endpoint) "
                 "or logins: a security section (docs/std-network.md)", insecure)
    stop = threading.Event()
    failed: list[JSONObject] = []
    ctrl_c = _CtrlC(stop)
    old = signal.getsignal(signal.SIGTERM)
    try:
        sigs.install(signal.SIGTERM, ctrl_c.on_sigterm)
        with ctrl_c, rt:
            ctrl_c.started = True
            where = f", control endpoint {rt.endpoint}" if rt.control else ""
            if rt.local_endpoint:   # secured endpoint: this computer's processes come here
                where += f" (local: {rt.local_endpoint})"
            click.echo(f"robot {rt.robot!r} running in {rt.mode_name} mode{where} "
                       f"({len(rt.ls())} components)", err=True)
            from ..hmi.child import HmiChild
            children: list[HmiChild] = []
            if top is None:
                top = seconds is None and sys.stdout.isatty()
            try:
                for on, name, listen in ((hmi, "hmi", hmi_listen),
                                         (foxglove, "foxglove", foxglove_listen)):
                    if on:
                        child = HmiChild(rt.local_endpoint or rt.endpoint, listen,
                                         insecure=insecure, command=name)
                        children.append(child)
                        click.echo(f"{name}: {child.start()}", err=True)
                if top:
                    _live(rt, stop, seconds)
                else:
                    sigs.wait(stop, seconds)     # a SIGTERM on any thread ends it
            finally:
                for child in children:
                    child.stop()
            ctrl_c.stopping = True
            if seconds is not None and not ctrl_c.hit:
                click.echo(_table(rt.summary(), SUMMARY_COLS))
                failed = [r for r in rt.ls() if r["state"] == "failed"]
    except KeyboardInterrupt:
        pass                        # Ctrl-C while starting: the runtime stopped what ran
    except TransportError as exc:
        raise _plain(exc, rt.endpoint) from None
    signal.signal(signal.SIGTERM, old)
    if ctrl_c.hit:
        click.echo(f"interrupted: robot {rt.robot!r} stopped", err=True)
    for row in failed:            # --run: a failed component fails the run (exit status 1)
        why = f": {row['reason']}" if row.get("reason") else ""
        click.echo(f"error: {row['kind']} {row['name']!r} failed{why}", err=True)
    # Everything is stopped and closed. Leave without interpreter finalisation: a Zenoh
    # (Rust) thread that calls into Python while the interpreter finalises aborts the
    # process ("FATAL: exception not rethrown"); os._exit skips finalisation.
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(INTERRUPTED if ctrl_c.hit else 1 if failed else 0)


class _CtrlC:
    """SIGINT while ``esair std run`` runs: the first stops the robot (while starting, it
    interrupts the start, which stops what ran); later ones are ignored while it stops.
    SIGTERM likewise (:meth:`on_sigterm`), with exit status 0."""

    def __init__(self, stop: threading.Event):
        self.stop = stop
        self.hit = False
        self.started = False
        self.stopping = False
        self.old: object = None        # the handler SIGINT had

    def __enter__(self) -> "_CtrlC":
        # started with SIGINT ignored (a shell's background job): it stays ignored
        self.old = sigs.install(signal.SIGINT, self._on_sigint)
        return self

    def __exit__(self, *exc: object) -> None:
        # a Ctrl-C while the runtime stops is ignored (nothing to print)
        signal.signal(signal.SIGINT, signal.SIG_IGN)

    def _on_sigint(self, *_: object) -> None:
        first = not self.hit
        self.hit = True
        self._stop_now(first)

    def on_sigterm(self, *_: object) -> None:
        """SIGTERM (a service manager's stop, exit status 0): the robot stops; while it
        starts, the start is interrupted as Ctrl-C interrupts it (a resource whose open
        hangs would otherwise hold the stop up to its own time limit)."""
        self._stop_now(first=not self.stop.is_set())

    def _stop_now(self, first: bool) -> None:
        self.stop.set()
        if first and not self.started:
            raise KeyboardInterrupt


def _secured(rt: Runtime) -> bool:
    """Whether only those who prove who they are reach the control endpoint: TLS with
    client certificates on a tls/ or quic/ endpoint, or Zenoh logins."""
    sec = getattr(rt.deployment, "security", None)
    if sec is None:
        return False
    tls = rt.endpoint.startswith(("tls/", "quic/")) and sec.cert is not None and sec.mtls
    return bool(tls or sec.users is not None)


def _plain(exc: Exception, endpoint: str) -> Exception:
    """Zenoh's words for a listener that cannot open, as a user's."""
    from ..errors import TransportError
    text = str(exc)
    if "Address already in use" in text:
        return TransportError(f"{endpoint}: port in use, choose another with -e")
    if "Cannot assign requested address" in text or "Can not create a new TCP listener" in text:
        return TransportError(f"{endpoint}: cannot listen there (no such address on this "
                              "computer?), choose another with -e")
    return exc
