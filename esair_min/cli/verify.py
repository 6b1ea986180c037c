"""``esair new`` and ``esair verify`` (docs/verify.md)."""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

import click

from esair_min.cli.pipes import friendly


@click.command(short_help="Copy a bundled robot's board files into DIR, to edit.")
@click.argument("robot", metavar="ROBOT")
@click.argument("folder", metavar="DIR")
@friendly
def new(robot: str, folder: str) -> None:
    """Copy bundled robot ROBOT (papaman, papaman-avr, starfish, starfish-avr) into DIR,
    its board files renamed after the folder: a working robot to start from. The copy
    passes `esair check DIR`; prove it with `esair verify DIR`."""
    from esair_min.verify.new import copy_robot

    for path in copy_robot(robot, folder):
        click.echo(f"wrote {path}")
    click.echo(f"check it: esair check {folder}; prove it: esair verify {folder}")


@click.command(short_help="Run a scenario on every target; compare traces; check budgets.")
@click.argument("robot", metavar="ROBOT")
@click.option("--script", "script", type=click.Path(dir_okay=False, exists=True),
              metavar="FILE", help="A stimulus script (docs/trace-format.md) instead of the "
                                   "scenario generated from the board files.")
@click.option("--targets", metavar="LIST",
              help="Comma-separated among python,host,pic,avr (default: every target the "
                   "robot's MCUs allow).")
@click.option("--json", "as_json", is_flag=True, help="Print the report as JSON.")
@click.option("--work", type=click.Path(file_okay=False), metavar="DIR",
              help="Keep the firmware, scenario and simulator files here (default: a "
                   "temporary folder, removed).")
@friendly
def verify(robot: str, script: str | None, targets: str | None, as_json: bool,
           work: str | None) -> None:
    """Prove ROBOT on every target before it touches hardware: the Python core, the
    generated C on the host, and the central board's chip in its simulator (gpsim for the
    PIC18F452, simavr for the ATmega328P) run the same scenario; their replies, register
    writes and reactions must agree with the Python core's (actuator writes on its tick,
    within the ticks the command line takes to arrive). The chip simulators' timing
    budgets (decoder per byte, worst ISR, the tick's bus work, stack, flash, RAM) are
    checked against the board files' settings. Exit status 1 on a difference or a budget
    over; the report says the number and what to change."""
    from esair_min.model.validate import load_robot
    from esair_min.resources import resolve_robot
    from esair_min.verify.report import report_lines
    from esair_min.verify.runner import verify as run_verify
    from esair_min.verify.targets import choose_targets

    model = load_robot(resolve_robot(robot))
    chosen = choose_targets(model, targets)
    text = Path(script).read_text(errors="replace") if script else None

    def progress(line: str) -> None:
        click.echo(line, err=as_json)

    def go(folder: Path):
        return run_verify(model, chosen, folder, text, script or "", progress)

    if work:
        report = go(Path(work))
    else:
        with tempfile.TemporaryDirectory(prefix="esair-verify-") as tmp:
            report = go(Path(tmp))
    if as_json:
        click.echo(json.dumps(report.as_dict(), indent=2))
    else:
        for line in report_lines(report):
            click.echo(line)
    if not report.ok:
        sys.exit(1)


COMMANDS = (new, verify)
