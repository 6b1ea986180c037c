"""``esair std run``: deploy a robot and keep it running (or ``--run SECONDS``, headless,
then a summary)."""

from __future__ import annotations

import os
import signal
import sys
import threading
import time
from typing import Any

import click

from esair_min.cli.pipes import friendly

from .table import table as _table


def _with_port(path: Any, port: str) -> Any:
    """The deployment with ``port`` set on every resource that has a ``port`` option."""
    import yaml

    from ..deploy import load_deployment
    try:
        with open(path) as f:
            raw = yaml.safe_load(f)
    except (OSError, yaml.YAMLError):
        return path                      # loading it reports the error at file:line:col
    if not isinstance(raw, dict):
        return path
    for entry in (raw.get("resources") or {}).values():
        if isinstance(entry, dict) and "port" in entry:
            entry["port"] = port
            entry.pop("emulate", None)
    return load_deployment(raw, base_dir=os.path.dirname(os.path.abspath(path)))


class _Local:
    """The runtime seen through the control client's one method (for the live table)."""

    def __init__(self, rt: Any):
        self.rt = rt
        self.robot = rt.robot

    def call(self, verb: str, body: dict | None = None) -> Any:
        return self.rt.ls() if verb == "ls" else self.rt.inspect((body or {})["name"])


def _live(rt: Any, stop: threading.Event, seconds: float | None) -> None:
    from rich.live import Live

    from .top import render, snapshot
    local, before = _Local(rt), {}
    end = None if seconds is None else time.monotonic() + seconds
    with Live(render(snapshot(local), before, rt.robot), auto_refresh=False) as live:
        while not stop.wait(1.0):
            live.update(render(snapshot(local), before, rt.robot), refresh=True)
            if end is not None and time.monotonic() >= end:
                break


SUMMARY_COLS = ["name", "kind", "state", "samples", "overwritten", "commands", "puts_ok",
                "puts_failed", "restarts"]


@click.command("run")
@click.argument("deployment", metavar="FILE")
@click.option("--mode", type=click.Choice(["thread", "process"]), default=None,
              help="Override the file's mode.")
@click.option("--run", "seconds", type=click.FloatRange(min=0), default=None,
              metavar="SECONDS", help="Run headless this long, then print a summary and stop.")
@click.option("-e", "--endpoint", default=None, metavar="tcp/HOST:PORT",
              help="Control endpoint to listen on (default: the file's).")
@click.option("--no-control", is_flag=True,
              help="Thread mode: open no control endpoint (no network at all).")
@click.option("--port", default=None, metavar="DEVICE",
              help="Set the `port` option of every resource that has one (a serial device, "
                   "a pty, an esair:// URL), e.g. the real robot's /dev/ttyUSB0.")
@click.option("--top/--no-top", "top", default=None,
              help="Show the live table of `esair std top` while running (default: when "
                   "the output is a terminal and --run is not given).")
@click.option("--join", "join", multiple=True, metavar="tcp/HOST:PORT",
              help="Another robot's control endpoint to join (repeat): behaviors then put "
                   "to and get from its behaviors as ROBOT/NAME.")
@friendly
def run_cmd(deployment: str, mode: str | None, seconds: float | None, endpoint: str | None,
            no_control: bool, port: str | None, top: bool | None,
            join: tuple[str, ...]) -> None:
    """Deploy FILE (a deployment file, or a bundled example such as `lab`) and run it
    until Ctrl-C, or for --run SECONDS. Other terminals control it with `esair std ls`,
    `add`, `remove`, `put`, ... over the control endpoint."""
    from ..deploy.bundled import resolve_deployment
    from ..runtime import Runtime

    path: Any = resolve_deployment(deployment)
    if port is not None:
        path = _with_port(path, port)
    rt = Runtime(path, mode=mode, endpoint=endpoint,
                 control=None if not no_control else False, join=list(join))
    if rt.mode_name == "thread" and not no_control:
        rt.control = True
    stop = threading.Event()
    old = signal.signal(signal.SIGTERM, lambda *_: stop.set())
    with rt:
        where = f", control endpoint {rt.endpoint}" if rt.control else ""
        if rt.local_endpoint:       # secured endpoint: this computer's processes come here
            where += f" (local: {rt.local_endpoint})"
        click.echo(f"robot {rt.robot!r} running in {rt.mode_name} mode{where} "
                   f"({len(rt.ls())} components)", err=True)
        if top is None:
            top = seconds is None and sys.stdout.isatty()
        try:
            if top:
                _live(rt, stop, seconds)
            else:
                stop.wait(seconds)
        except KeyboardInterrupt:
            pass
        if seconds is not None:
            click.echo(_table(rt.summary(), SUMMARY_COLS))
    signal.signal(signal.SIGTERM, old)
    # Everything is stopped and closed. Leave without interpreter finalisation: a Zenoh
    # (Rust) thread that calls into Python while the interpreter finalises aborts the
    # process ("FATAL: exception not rethrown") — seen rarely, never with os._exit.
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)


