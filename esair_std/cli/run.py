"""``esair std run``: deploy a robot and keep it running (or ``--run SECONDS``, headless,
then a summary)."""

from __future__ import annotations

import os
import signal
import sys
import threading

import click

from ..deploy.bundled import resolve_deployment
from . import friendly


def _table(rows: list[dict], cols: list[str]) -> str:
    widths = {c: max(len(c), *(len(str(r.get(c, ""))) for r in rows)) if rows else len(c)
              for c in cols}
    out = ["  ".join(c.upper().ljust(widths[c]) for c in cols)]
    for r in rows:
        out.append("  ".join(str(r.get(c, "")).ljust(widths[c]) for c in cols))
    return "\n".join(line.rstrip() for line in out)


SUMMARY_COLS = ["name", "kind", "state", "samples", "overwritten", "puts_ok", "puts_failed",
                "restarts"]


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
@friendly
def run_cmd(deployment: str, mode: str | None, seconds: float | None, endpoint: str | None,
            no_control: bool) -> None:
    """Deploy FILE (a deployment file, or a bundled example such as `lab`) and run it
    until Ctrl-C, or for --run SECONDS. Other terminals control it with `esair std ls`,
    `add`, `remove`, `put`, ... over the control endpoint."""
    from ..runtime import Runtime

    path = resolve_deployment(deployment)
    rt = Runtime(path, mode=mode, endpoint=endpoint,
                 control=None if not no_control else False)
    if rt.mode_name == "thread" and not no_control:
        rt.control = True
    stop = threading.Event()
    old = signal.signal(signal.SIGTERM, lambda *_: stop.set())
    with rt:
        where = f", control endpoint {rt.endpoint}" if rt.control else ""
        click.echo(f"robot {rt.robot!r} running in {rt.mode_name} mode{where} "
                   f"({len(rt.ls())} components)", err=True)
        try:
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


