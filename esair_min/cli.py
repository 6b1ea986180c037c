"""The ``esair`` command line. The only place that turns errors into exit codes."""

from __future__ import annotations

import json
import sys
from functools import wraps
from typing import Any, Callable

import click

from . import __version__
from .errors import EsairError
from .resources import resolve_robot


def _friendly(fn: Callable[..., Any]) -> Callable[..., Any]:
    """Run ``fn``; an EsairError becomes one line on stderr and exit status 1."""

    @wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return fn(*args, **kwargs)
        except EsairError as exc:
            click.echo(f"error: {exc}", err=True)
            sys.exit(1)

    return wrapper


ROBOT = click.argument("robot", metavar="ROBOT")


def load(robot: str):
    from .validate import load_robot

    return load_robot(resolve_robot(robot))


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="esair")
def main() -> None:
    """ESAIR MIN: describe each board of a robot in YAML, check it, generate its
    firmware and motion EEPROM image, and run an emulated robot behind a serial port.

    ROBOT is a folder of board files (boards/papaman), one board file, or the name of
    a bundled example (papaman).
    """


@main.command()
@ROBOT
@_friendly
def check(robot: str) -> None:
    """Validate a robot's board files and print a short summary."""
    from .summary import robot_summary

    model = load(robot)
    for line in robot_summary(model):
        click.echo(line)
    click.echo("ok")


@main.command()
@click.option("--indent", default=2, show_default=True, help="JSON indentation.")
def schema(indent: int) -> None:
    """Print the JSON Schema of the board file format (for editors)."""
    from .model import Board

    doc = Board.model_json_schema()
    doc["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    doc["title"] = "ESAIR MIN board file"
    click.echo(json.dumps(doc, indent=indent, sort_keys=True))


@main.command()
@ROBOT
@click.option("-o", "--output", required=True, metavar="FILE",
              help="Where to write the image (Intel HEX, or raw with --bin).")
@click.option("--bin", "raw", is_flag=True, help="Write raw bytes instead of Intel HEX.")
@_friendly
def eeprom(robot: str, output: str, raw: bool) -> None:
    """Build the EEPROM motion image of a robot and write it as Intel HEX."""
    from .errors import ImageError
    from .image import build_image, image_summary, write_hex

    model = load(robot)
    data = build_image(model)
    if raw:
        try:
            with open(output, "wb") as f:
                f.write(data)
        except OSError as exc:
            raise ImageError(f"cannot write {output}: {exc.strerror}") from None
    else:
        write_hex(data, output)
    click.echo(f"{image_summary(model, data)} -> {output}")


@main.command()
@ROBOT
@click.option("-o", "--output", required=True, metavar="DIR",
              help="Output folder: one sub-folder per board (central, actuator, sensor).")
@_friendly
def generate(robot: str, output: str) -> None:
    """Generate the C firmware of every board (core, hal.h, PIC and host ports, Makefile)."""
    from pathlib import Path

    from codegen import generate_robot

    result = generate_robot(load(robot), Path(output))
    click.echo(f"{', '.join(result.boards)}: {len(result.written)} files written, "
               f"{len(result.unchanged)} unchanged in {output}")


if __name__ == "__main__":  # pragma: no cover
    main()
