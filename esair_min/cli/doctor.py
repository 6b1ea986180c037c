"""``esair doctor ROBOT --port PORT``: the bring-up checklist of a real robot
(esair_min.bringup)."""

from __future__ import annotations

import click

from esair_min.cli.pipes import friendly
from esair_min.errors import EsairError


@click.command(short_help="Check a real robot's board, wiring and motions, with hints.")
@click.argument("robot")
@click.option("--port", required=True, metavar="PORT",
              help="The central board's serial port (/dev/ttyUSB0, a pty, esair://...).")
@click.option("--baud", type=int, metavar="BAUD",
              help="The line's baud (default: the central board file's).")
@click.option("--move", is_flag=True,
              help="Also move each servo in turn a few degrees around its stand angle, "
                   "slowly, inside its limits (keep the robot clear).")
@click.option("--timeout", type=float, default=2.0, show_default=True,
              help="Seconds to wait for each reply.")
@friendly
def doctor(robot: str, port: str, baud: int | None, move: bool, timeout: float) -> None:
    """Check ROBOT's central board on PORT, one line a check, PASS or FAIL with a hint:
    the port opens (or who holds it); the board answers 'v' at the board file's baud
    (or which common baud answered instead); the reply is ROBOT's (servos, sensors,
    motions), its firmware the build of these board files and its motion image theirs
    (CRC); every I2C device of the board files acknowledges; each sensor reads inside
    its range; with --move, each servo moves. Exit status 1 if any check failed."""
    import serial

    from esair_min.cli.flash import _load
    from esair_min.bringup import Check, Doctor
    from esair_min.flash.portlock import holder
    from esair_min.serialport import describe, open_port

    model = _load(robot)
    rate = baud or (model.central.uart.baud if model.central.uart else 9600)
    try:
        ser = open_port(port, baudrate=rate, timeout=0.05)
    except (serial.SerialException, ValueError, OSError) as exc:
        who = holder(port) if "://" not in port else None
        why = f"held by {who}" if who else describe(exc)
        hint = ("stop that program first (or use its own commands)" if who else
                "check the port's name (ls /dev/ttyUSB* /dev/ttyACM*), that the board is "
                "plugged in, and that you may use it (group dialout)")
        for line in Check("port", False, f"{port}: {why}", hint).lines():
            click.echo(line)
        raise SystemExit(1) from None
    failed = 0
    with ser:
        click.echo(f"PASS  port: {port} opened at {rate} baud")
        checks = Doctor(model, ser, port, rate, timeout).run(
            move, on_move=lambda text: click.echo(f"      {text}", err=True))
        try:
            for check in checks:
                failed += not check.ok
                for line in check.lines():
                    click.echo(line)
        except (serial.SerialException, OSError) as exc:
            raise EsairError(f"{port}: {describe(exc)}") from None
    click.echo(f"{model.name}: {'all checks passed' if not failed else f'{failed} failed'}")
    if failed:
        raise SystemExit(1)
