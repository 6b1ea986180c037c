"""``esair flash`` (put a board's firmware on its chip) and ``esair monitor`` (watch a
board's notices and replies, type commands). docs/hardware.md."""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from esair_min.cli.pipes import friendly
from esair_min.flash import FlashError

if TYPE_CHECKING:   # the model (pydantic) is imported by the commands that load a robot:
    from esair_min.model.robot import Robot   # `esair std ...` starts without it


def _load(robot: str) -> Robot:
    from esair_min.model.validate import load_robot
    from esair_min.resources import resolve_robot

    return load_robot(resolve_robot(robot))


class _Bar:
    """Progress: a bar redrawn in place on a terminal, plain lines (each quarter) otherwise."""

    def __init__(self, tty: bool) -> None:
        self.tty = tty
        self.shown: tuple[str, int] = ("", -1)

    def __call__(self, phase: str, percent: int) -> None:
        if self.tty:
            filled = percent * 30 // 100
            click.echo(f"\r{phase:<9} [{'#' * filled}{'.' * (30 - filled)}] {percent:3d}%",
                       nl=percent >= 100, err=True)
            return
        quarter = percent // 25
        if (phase, quarter) != self.shown:
            click.echo(f"{phase}: {quarter * 25}%", err=True)
            self.shown = (phase, quarter)


def _flash_pic(hex_path: Path, port: str, baud: int | None, progress: _Bar,
               wait: float = 10.0) -> None:
    import importlib

    try:    # the PIC path (esair_min/flash/pic.py) comes with ESAIR's PIC bootloader
        pic = importlib.import_module("esair_min.flash.pic")
    except ModuleNotFoundError:
        raise FlashError("a PIC18F452 board is flashed through ESAIR's own serial bootloader, "
                         "which this version of ESAIR does not have yet (Debian has no PIC "
                         "programmer package): program it with the PIC vendor's tools "
                         "(docs/hardware.md)") from None
    pic.flash_pic(hex_path, port, baud=baud or 115200, progress=progress, connect_timeout=wait)


@click.command(short_help="Put a board's firmware on its chip (avrdude for ATmega328P).")
@click.argument("robot", metavar="ROBOT")
@click.option("--board", "role", required=True, metavar="NAME",
              help="The board to flash (central, actuator, sensor...).")
@click.option("--port", required=True, metavar="PORT",
              help="The board's serial port (/dev/ttyUSB0), or the programmer's (usb).")
@click.option("--bootloader", type=click.Choice(["optiboot", "atmegaboot"]), default="optiboot",
              show_default=True,
              help="The board's bootloader: optiboot (Uno, new Nano: 115200 baud) or "
                   "atmegaboot (old Nano: 57600).")
@click.option("--programmer", metavar="NAME",
              help="An avrdude programmer for a bare chip (usbasp, avrisp, stk500v2...) "
                   "instead of the bootloader.")
@click.option("--baud", type=int, help="The line's baud rate (default: the bootloader's).")
@click.option("--fuses", "write_fuses", is_flag=True,
              help="With --programmer: also write the fuses the board file's clock needs "
                   "(asks first).")
@click.option("--yes", is_flag=True, help="Do not ask before writing fuses.")
@click.option("--attempts", type=click.IntRange(1, 20), default=3, show_default=True,
              help="Times avrdude tries to reach the bootloader (about 5 s each).")
@click.option("--wait", type=click.FloatRange(0.5, 600), default=10.0, show_default=True,
              metavar="SECONDS",
              help="A PIC18F452 board: how long to say hello to its bootloader (reset the "
                   "board meanwhile).")
@click.option("-o", "--output", "build_dir", metavar="DIR",
              help="The build folder (default build/ROBOT); built first when a board file "
                   "is newer than the .hex.")
@click.option("--dry-run", is_flag=True, help="Print the avrdude command; change nothing.")
@friendly
def flash(robot: str, role: str, port: str, bootloader: str, programmer: str | None,
          baud: int | None, write_fuses: bool, yes: bool, attempts: int, wait: float,
          build_dir: str | None, dry_run: bool) -> None:
    """Build (if needed), write and verify one board's firmware.

    An ATmega328P board goes through avrdude: by default its Arduino bootloader over the
    board's USB-serial; with --programmer any avrdude programmer (a bare chip; --fuses
    then also writes the fuses its clock needs). The port's lock is held throughout:
    a port another ESAIR program has open is refused.
    """
    from esair_min.flash.avrdude import AvrFlash, flash_avr, fuses_for
    from esair_min.flash.firmware import firmware
    from esair_min.flash.portlock import PortLock

    model = _load(robot)
    out = Path(build_dir) if build_dir else Path("build") / model.name
    fw = firmware(model, out, role, build=not dry_run)
    if fw.built:
        click.echo(f"built {fw.hex_path}", err=True)
    if write_fuses and not programmer:
        raise FlashError("--fuses needs --programmer: a bootloader cannot change fuses")
    bar = _Bar(sys.stderr.isatty())
    if fw.part == "pic18f452":
        if dry_run:
            click.echo(f"flash_pic {fw.hex_path} {port} (ESAIR's serial bootloader)")
            return
        with PortLock(port):
            _flash_pic(fw.hex_path, port, baud, bar, wait)
        click.echo(f"{role}: {fw.hex_path} written to {port} and verified")
        return
    fuses = None
    if write_fuses:
        fuses, why = fuses_for(fw.clock_hz)
        click.echo(f"fuses: {fuses.describe()} ({why})", err=True)
    plan = AvrFlash(fw.hex_path, port, fw.part, programmer or "arduino", bootloader, baud,
                    attempts, fuses)
    if dry_run:
        click.echo(" ".join(plan.command()))
        return
    if fuses is not None and not yes:
        click.confirm(f"write these fuses to the chip on {port}? wrong fuses can leave "
                      "it needing a clock to recover", abort=True, err=True)
    start = time.monotonic()
    with PortLock(port) as lock:
        flash_avr(plan, bar, watch_fd=lock.fd)
    click.echo(f"{role}: {fw.image_bytes()} bytes written to {port} and verified "
               f"({time.monotonic() - start:.1f} s)")


@click.command(short_help="Watch a board's notices and replies; type commands.")
@click.argument("port")
@click.option("--baud", type=int, default=9600, show_default=True,
              help="Baud rate of a real serial port.")
@click.option("--robot", metavar="ROBOT",
              help="The robot's board files: reactions and motions by name.")
@click.option("--log", "log_path", type=click.Path(dir_okay=False), metavar="FILE",
              help="Also append every line shown to FILE.")
@friendly
def monitor(port: str, baud: int, robot: str | None, log_path: str | None) -> None:
    """Show what the board sends, time-stamped and decoded, and send the lines you type
    (line editing and history on a terminal). Nothing is sent that you did not type.
    Ctrl-C ends it (exit status 130).

    PORT is a serial device, the pty of 'esair emulate --pty', or an esair:// URL.
    """
    from esair_min.cli.monitorloop import run_monitor

    model = None
    if robot:
        model = _load(robot)
    sys.exit(run_monitor(port, baud, model, Path(log_path) if log_path else None))


def _ports(ports: tuple[str, ...], model: Robot) -> dict[str, str]:
    """``--port PORT`` (the central board's) and ``--port BOARD=PORT``, by board role."""
    out: dict[str, str] = {}
    roles = [b.role for b in model.boards]
    central = model.central.role if model.central is not None else roles[0]
    for item in ports:
        role, sep, port = item.partition("=")
        if not sep:
            role, port = central, item
        if role not in roles:
            raise click.BadParameter(f"{item!r}: robot '{model.name}' has no board '{role}' "
                                     f"(its boards: {', '.join(roles)})", param_hint="'--port'")
        out[role] = port
    if central not in out:
        raise click.BadParameter(f"give the {central} board's port (--port PORT): the "
                                 "monitor watches it", param_hint="'--port'")
    return out


def _line_starting(ser: Any, prefix: str, timeout: float, ask: bytes = b"") -> str | None:
    """The first line from ``ser`` that starts with ``prefix``, read line by line so that
    nothing after it is taken; ``ask`` is sent first and again every 0.5 s (a board still
    starting misses it). None when none comes in ``timeout``."""
    import time as _time

    buf = b""
    deadline = _time.monotonic() + timeout
    asked = 0.0
    while _time.monotonic() < deadline:
        if ask and _time.monotonic() - asked > 0.5:
            ser.write(ask)
            asked = _time.monotonic()
        buf += ser.readline()
        if buf.endswith(b"\n"):
            line = buf.decode("latin-1").strip()
            buf = b""
            if line.startswith(prefix):
                return line
    return None


def _wait_ready(ser: Any, timeout: float = 10.0) -> str | None:
    """The board's ``!READY`` line on an open port (opening it reset an Arduino; its
    bootloader waits first). 10 s, as for a PIC's ``v``: a slow USB adapter or a
    simulated chip on a busy computer may take seconds."""
    return _line_starting(ser, "!READY", timeout)


def _booted(link: Any, part: str, wait: float = 10.0) -> str | None:
    """The central board's boot line: its ``!READY`` (opening the port reset an Arduino),
    or for a PIC18F452 board, which no port reset reaches, its reply to ``v``; None
    when none comes in ``wait`` seconds."""
    if part != "pic18f452":
        return _wait_ready(link, wait)
    link.reset_input_buffer()
    return _line_starting(link, "OK esair-min", wait, ask=b"v\r\n")


def _write_motions(model: Robot, ser: Any) -> None:
    """The robot's motion image into its EEPROM over its link (only what differs)."""
    from esair_min.core.image import build_image
    from esair_min.imagelink import ImageLink

    image = build_image(model)
    ser.timeout = 0.05
    res = ImageLink(ser, model).write_image(image)
    if res.written == 0:
        click.echo(f"motions: the robot already holds them (CRC 0x{res.crc:04X})")
    else:
        click.echo(f"motions: wrote {res.written} of {res.chunks} chunks ({len(image)} bytes) "
                   f"in {res.seconds:.1f} s, CRC 0x{res.crc:04X}")


@click.command(short_help="Build, flash what changed, then monitor a real robot.")
@click.argument("robot", metavar="ROBOT")
@click.option("--port", "ports", multiple=True, required=True, metavar="[BOARD=]PORT",
              help="The central board's port; BOARD=PORT for another board (repeatable).")
@click.option("--bootloader", type=click.Choice(["optiboot", "atmegaboot"]), default="optiboot",
              show_default=True, help="The boards' bootloader (as esair flash).")
@click.option("--attempts", type=click.IntRange(1, 20), default=3, show_default=True,
              help="Times avrdude tries to reach a bootloader.")
@click.option("--wait", type=click.FloatRange(0.5, 600), default=10.0, show_default=True,
              metavar="SECONDS",
              help="How long the central board has to say which build it runs before it "
                   "is flashed (a board holding no application never says).")
@click.option("-o", "--output", "build_dir", metavar="DIR",
              help="The build folder (default build/ROBOT).")
@click.option("--log", "log_path", type=click.Path(dir_okay=False), metavar="FILE",
              help="The monitor's log (as esair monitor --log).")
@friendly
def run(robot: str, ports: tuple[str, ...], bootloader: str, attempts: int, wait: float,
        build_dir: str | None, log_path: str | None) -> None:
    """Build the robot (if a board file changed), flash each board given a port unless
    it already runs the built firmware (the central board: the build id of its !READY;
    another: its flash read back and compared through its bootloader), write the motions
    into the robot's EEPROM over its link if its image differs, then monitor the central
    board as esair monitor does (Ctrl-C ends it).
    """
    from esair_min.cli.monitorloop import run_monitor
    from esair_min.flash.avrdude import AvrFlash, flash_avr, holds_image
    from esair_min.flash.firmware import firmware
    from esair_min.flash.portlock import PortLock

    from esair_min.cli.send import open_port
    from esair_min.codegen.buildid import central_build_id

    model = _load(robot)
    by_role = _ports(ports, model)
    out = Path(build_dir) if build_dir else Path("build") / model.name
    bar = _Bar(sys.stderr.isatty())
    central = model.central.role if model.central is not None else model.boards[0].role
    board = model.board(central)
    baud = board.uart.baud if board is not None and board.uart is not None else 9600
    link: Any = None                     # the central board's port, kept open once it booted
    for role, port in by_role.items():
        fw = firmware(model, out, role)
        if fw.built:
            click.echo(f"built {out}", err=True)
        if role == central:
            link = open_port(port, baud, 0.1)       # (opening resets an Arduino)
            ready = _booted(link, fw.part, wait)
            want = central_build_id(model)
            if ready is not None and f"build={want}" in ready.split():
                click.echo(f"{role}: {port} already runs build {want}: not flashed")
                continue
            link.close()
            link = None
        if fw.part == "pic18f452":
            with PortLock(port):
                _flash_pic(fw.hex_path, port, None, bar)
            click.echo(f"{role}: written to {port} and verified")
            continue
        plan = AvrFlash(fw.hex_path, port, fw.part, "arduino", bootloader, None, attempts)
        with PortLock(port) as lock:
            if role != central and holds_image(plan, bar, watch_fd=lock.fd):
                click.echo(f"{role}: {port} already holds the built firmware: not flashed")
                continue
            flash_avr(plan, bar, watch_fd=lock.fd)
        click.echo(f"{role}: {fw.image_bytes()} bytes written to {port} and verified")
    port = by_role[central]
    if link is None:
        link = open_port(port, baud, 0.1)
        if _booted(link, firmware(model, out, central).part) is None:
            link.close()
            raise FlashError(f"the central board on {port} did not say !READY after the "
                             "flash (is its firmware running? esair monitor shows it)")
    try:
        if model.central is not None and model.central.motions:
            _write_motions(model, link)
    except BaseException:
        link.close()
        raise
    sys.exit(run_monitor(port, baud, model, Path(log_path) if log_path else None, link))
