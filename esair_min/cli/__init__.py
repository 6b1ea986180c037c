"""The ``esair`` command line. The only place that turns errors into exit codes."""

from __future__ import annotations

import importlib.metadata
import json
import sys

import click

from esair_min import __version__
from esair_min.cli import verify as _verify
from esair_min.cli.pipes import friendly
from esair_min.resources import resolve_robot


ROBOT = click.argument("robot", metavar="ROBOT")
OUTPUT_DIR = click.option("-o", "--output", required=True, metavar="DIR",
                          help="Output folder: one sub-folder per board "
                               "(central, actuator, sensor).")


def load(robot: str):
    from esair_min.model.validate import load_robot

    return load_robot(resolve_robot(robot))


#: the entry-point group through which the other halves mount their commands on ``esair``
#: (ESAIR STD declares ``std = "esair_std.cli:std"`` in pyproject.toml), so MIN never
#: imports them: each is imported only when its command is used
COMMANDS_GROUP = "esair.commands"


def _mounted() -> dict[str, importlib.metadata.EntryPoint]:
    return {ep.name: ep for ep in importlib.metadata.entry_points(group=COMMANDS_GROUP)}


class _Esair(click.Group):
    """The ``esair`` group: MIN's commands, and the groups mounted through
    :data:`COMMANDS_GROUP` (``esair std ...``), imported only when used."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted({*super().list_commands(ctx), *_mounted()})

    def get_command(self, ctx: click.Context, name: str) -> click.Command | None:
        mounted = _mounted().get(name)
        if mounted is not None and name not in self.commands:
            return mounted.load()
        return super().get_command(ctx, name)


@click.group(cls=_Esair, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="esair")
def main() -> None:
    """ESAIR MIN: describe each board of a robot in YAML, check it, generate its
    firmware and motion EEPROM image, and run an emulated robot behind a serial port.

    ROBOT is a folder of board files (boards/papaman), one board file, or the name of
    a bundled example (papaman, papaman-avr, starfish, starfish-avr).
    """


@main.command()
@ROBOT
@friendly
def check(robot: str) -> None:
    """Validate a robot's board files and print a short summary.

    Given one board file that is not a whole robot (an actuator or sensor board, or a
    central board with peers), checks that board on its own rules and says which rules
    need the robot's folder.
    """
    from esair_min.model.summary import board_summary, robot_summary
    from esair_min.model.validate import check_board_alone, is_whole_robot

    path = resolve_robot(robot)
    if path.is_file():
        board = check_board_alone(path)
        if not is_whole_robot(board):
            for line in board_summary(board, str(path.parent)):
                click.echo(line)
            click.echo("ok")
            return
    model = load(robot)
    for line in robot_summary(model):
        click.echo(line)
    click.echo("ok")


@main.command()
@click.option("--indent", default=2, show_default=True, help="JSON indentation.")
def schema(indent: int) -> None:
    """Print the JSON Schema of the board file format (for editors)."""
    from esair_min.model.board import Board

    doc = Board.model_json_schema()
    doc["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    doc["title"] = "ESAIR MIN board file"
    click.echo(json.dumps(doc, indent=indent, sort_keys=True))


@main.command(short_help="Build the EEPROM motion image; write it into a robot (--write).")
@ROBOT
@click.option("-o", "--output", metavar="FILE",
              help="Write the image to FILE (Intel HEX, or raw with --bin).")
@click.option("--bin", "raw", is_flag=True, help="With -o: raw bytes instead of Intel HEX.")
@click.option("--write", "write_port", metavar="PORT",
              help="Put the image into the robot on PORT over its link (only the chunks "
                   "that differ are written), then check it there.")
@click.option("--verify", "verify_port", metavar="PORT",
              help="Compare the robot's EEPROM on PORT with the image (status 1 if it differs).")
@click.option("--read", "read_file", metavar="FILE",
              help="Read the robot's image (from --port) into FILE (Intel HEX).")
@click.option("--port", metavar="PORT", help="The port for --read.")
@click.option("--baud", type=int, help="Baud of a real port (default: the board file's).")
@click.option("--timeout", type=float, default=3.0, show_default=True,
              help="Seconds to wait for each reply.")
@friendly
def eeprom(robot: str, output: str | None, raw: bool, write_port: str | None,
           verify_port: str | None, read_file: str | None, port: str | None,
           baud: int | None, timeout: float) -> None:
    """Build the EEPROM motion image of a robot (-o FILE), or put it into the robot over
    its serial link (--write PORT), compare (--verify PORT) or read it back (--read FILE
    --port PORT). Over the link the robot answers image=bad and plays nothing from the
    first chunk written until the commit has checked the whole image (docs/protocol.md)."""
    from esair_min.cli.eeprom import build_file, over_link

    modes = [m for m in (output, write_port, verify_port, read_file) if m is not None]
    if len(modes) != 1:
        raise click.UsageError("give one of -o FILE, --write PORT, --verify PORT, "
                               "--read FILE")
    if (read_file is None) != (port is None):
        raise click.UsageError("--port goes with --read (and --read needs it)")
    model = load(robot)
    if output is not None:
        click.echo(build_file(model, output, raw))
        return
    status = over_link(model, write_port or verify_port or port or "", baud,
                       write_port is not None, verify_port is not None, read_file, timeout)
    if status:
        sys.exit(status)


def _pose(text: str | None) -> tuple[float, float, float] | None:
    if text is None:
        return None
    import math

    try:
        x, y, theta = (float(v) for v in text.split(","))
    except ValueError:
        raise click.BadParameter(f"{text!r} is not X,Y,THETA (mm, mm, rad)",
                                 param_hint="'--pose'") from None
    if not all(math.isfinite(v) for v in (x, y, theta)):
        raise click.BadParameter(f"{text!r}: every number must be finite", param_hint="'--pose'")
    return x, y, theta


@main.command(short_help="Run the emulated robot on a pty (--pty) or headless (--run).")
@ROBOT
@click.option("--pty", is_flag=True,
              help="Serve on a new pseudo-terminal; its path is the first line printed.")
@click.option("--run", "run_s", type=float, metavar="SECONDS",
              help="Instead: run headless for SECONDS of virtual time, print the output.")
@click.option("--send", "sends", multiple=True, metavar="LINE",
              help="With --run: command lines sent back to back after boot.")
@click.option("--generate", type=click.Path(file_okay=False), metavar="DIR",
              help="First generate the firmware and EEPROM image into DIR.")
@click.option("--scenario", metavar="NAME|FILE",
              help="Sensor readings over time (a file, or a name in ROBOT/scenarios/).")
@click.option("--hold-scenario", is_flag=True,
              help="With --pty: the scenario plays when the emulator gets SIGUSR1, not at boot.")
@click.option("--trace", type=click.Path(dir_okay=False), metavar="FILE",
              help="Write the event trace (docs/trace-format.md, with @ time marks).")
@click.option("--trace-rx", is_flag=True,
              help="With --trace: also each line the robot received (RX lines).")
@click.option("--speed", type=float, metavar="FACTOR",
              help="With --pty: virtual seconds per wall second (default 1: real time).")
@click.option("--nack-actuator", is_flag=True, help="Fault: the actuator board never ACKs.")
@click.option("--no-sensor", is_flag=True, help="Fault: no sensor board on the bus.")
@click.option("--corrupt-eeprom", is_flag=True, help="Fault: one byte of the image flipped.")
@click.option("--eeprom", "eeprom_file", type=click.Path(dir_okay=False), metavar="FILE",
              help="Keep the EEPROM's contents in FILE across runs (a new file: a blank "
                   "EEPROM); every write goes to it at once.")
@click.option("--stuck-bus", is_flag=True,
              help="Fault: SCL held low; every I2C transfer times out (E10).")
@click.option("--noise", type=float, default=0.0, metavar="BYTES/S",
              help="Fault: random bytes injected into the robot's receive line.")
@click.option("--seed", type=int, default=0, show_default=True, help="Seed of the faults.")
@click.option("--strict-baud", is_flag=True,
              help="With --pty: bytes sent or read at another baud than the board file's "
                   "cross garbled, as on a real wire (a pty itself ignores the baud).")
@click.option("--instance", metavar="HEX8",
              help="This boot's instance in the 'v' reply's id (8 hex digits; with --pty "
                   "a random one by default, docs/protocol.md).")
@click.option("--room", type=click.Path(dir_okay=False), metavar="FILE",
              help="An omni-base robot's room (YAML: box, walls, landmarks); default 5 m x 5 m.")
@click.option("--pose", metavar="X,Y,THETA",
              help="An omni-base robot's start pose (mm, mm, rad); default: the room's centre.")
@click.option("--world-out", type=click.Path(dir_okay=False), metavar="SOCKET",
              help="With --pty, an omni-base robot: send its true pose each tick to this Unix "
                   "datagram socket (docs/emulator.md).")
@friendly
def emulate(robot: str, pty: bool, run_s: float | None, sends: tuple[str, ...],
            generate: str | None, scenario: str | None, hold_scenario: bool, trace: str | None,
            trace_rx: bool, speed: float | None, nack_actuator: bool, no_sensor: bool,
            corrupt_eeprom: bool, stuck_bus: bool,
            noise: float, seed: int, room: str | None, instance: str | None,
            pose: str | None, world_out: str | None, eeprom_file: str | None,
            strict_baud: bool) -> None:
    """Run the emulated robot behind a pseudo-terminal (--pty) or headless (--run).

    With --pty it serves until Ctrl-C or SIGTERM; when standard output is a terminal,
    a live view shows servos, sensors, each command with its reply, and errors;
    SIGUSR1 (kill -USR1 PID) plays the scenario again from its start.
    With --run, Ctrl-C stops the run and keeps what ran (output printed, trace
    written; exit status 130). Options that do not apply (--send with --pty, --speed
    with --run) are refused.
    """
    from pathlib import Path

    from esair_min.emulator.faults import Faults
    from esair_min.emulator.serve import EmulateOptions, emulate as run_emulator

    opts = EmulateOptions(
        pty=pty, run_s=run_s, sends=sends, generate=Path(generate) if generate else None,
        scenario=scenario, hold_scenario=hold_scenario, trace=Path(trace) if trace else None,
        trace_rx=trace_rx, speed=speed,
        faults=Faults(nack_actuator, no_sensor, corrupt_eeprom, noise, seed, stuck_bus),
        room=Path(room) if room else None, instance=instance, pose=_pose(pose),
        world_out=Path(world_out) if world_out else None,
        eeprom=Path(eeprom_file) if eeprom_file else None, strict_baud=strict_baud)
    status = run_emulator(load(robot), opts)
    if status:
        sys.exit(status)


@main.command(short_help="Send command lines to a port; print one reply per line.")
@click.argument("port")
@click.argument("commands", nargs=-1)
@click.option("--baud", type=int, default=9600, show_default=True,
              help="Baud rate of a real serial port.")
@click.option("--timeout", type=float, default=2.0, show_default=True,
              help="Seconds to wait for each reply.")
@click.option("--notices", is_flag=True, help="Also print '!' notice lines.")
@click.option("--checksum", is_flag=True, help="Append the *HH checksum to each line.")
@friendly
def send(port: str, commands: tuple[str, ...], baud: int, timeout: float, notices: bool,
         checksum: bool) -> None:
    """Send command lines and print one reply per line; exit 1 if any reply is an error.

    PORT is a serial device, the pty of 'esair emulate --pty', or an esair:// URL
    (esair://boards/papaman?speed=max).
    """
    from esair_min.cli.send import open_port, send_commands

    if not commands:
        raise click.UsageError(f"no commands to send; to watch the board's notices and "
                               f"replies and type commands, use: esair monitor {port}")
    ser = open_port(port, baud, timeout)
    try:
        failures = send_commands(ser, commands, timeout, click.echo, notices, checksum)
    finally:
        ser.close()
    if failures:
        sys.exit(1)


@main.command(short_help="Draw servo angles (or STARFISH's path) from a trace (PNG).")
@click.argument("trace", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, metavar="PNG", help="Image to write.")
@click.option("--robot", "robot", default="papaman", show_default=True,
              help="The robot the trace came from (servo names, limits, actuator address).")
@click.option("--targets", is_flag=True, help="Also draw the decoded targets (dashed).")
@friendly
def plot(trace: str, output: str, robot: str, targets: bool) -> None:
    """Plot servo angles over time from an event trace: positions simulated from its
    actuator writes with the emulator's servo model (--targets adds the targets).
    A STARFISH trace (esair emulate starfish --trace) is drawn as the robot's path on
    its room's map, with the wheels' speeds below. A FILE.mcap (`esair std record`) is
    drawn per channel, reactions marked."""
    from esair_min.emulator.starfish.pose_trace import is_starfish_trace

    if trace.endswith(".mcap"):
        from esair_min.cli.plotmcap import plot_mcap
        samples, values = plot_mcap(trace, output)
        click.echo(f"{samples} samples ({values} values) -> {output}")
        return
    if is_starfish_trace(trace):
        from esair_min.cli.plotroom import plot_room

        n = plot_room(trace, output)
        click.echo(f"{n} ticks -> {output}")
        return
    from esair_min.cli.plot import plot_trace

    n = plot_trace(load(robot), trace, output, targets)
    click.echo(f"{n} ticks -> {output}")


@main.command(short_help="Generate every board's C firmware (PIC and host ports).")
@ROBOT
@OUTPUT_DIR
@friendly
def generate(robot: str, output: str) -> None:
    """Generate the C firmware of every board (core, hal.h, PIC and host ports, Makefile)."""
    from pathlib import Path

    from esair_min.codegen import generate_robot

    result = generate_robot(load(robot), Path(output))
    click.echo(f"{', '.join(result.boards)}: {len(result.written)} files written, "
               f"{len(result.unchanged)} unchanged in {output}")
    for skipped in result.skipped:
        click.echo(f"not generated: {skipped}: no firmware templates for these device kinds "
                   "yet (their Python cores run in the emulator)")


@main.command(short_help="Generate and build every board for its MCU; print sizes.")
@ROBOT
@OUTPUT_DIR
@friendly
def build(robot: str, output: str) -> None:
    """Generate every board's firmware, build it for its MCU (PIC18F452: SDCC; ATmega328P:
    avr-gcc) and print its footprint (and an ATmega328P's fuses for a bare chip); a
    warning fails the build."""
    from pathlib import Path

    from esair_min.pic.build import build_robot, summary_lines

    model = load(robot)
    for line in summary_lines(build_robot(model, Path(output), boot=True)):
        click.echo(line)
    from esair_min.flash.avrdude import fuses_for

    for board in model.boards:
        if board.mcu.part == "atmega328p":
            fuses, _ = fuses_for(board.mcu.clock_hz)
            click.echo(f"{board.role}: a bare chip at {board.mcu.clock_hz / 1e6:g} MHz needs "
                       f"{fuses.describe()} (esair flash --programmer NAME --fuses)")


from esair_min.cli.flash import flash, monitor, run  # noqa: E402  (commands of real boards)

from esair_min.cli.doctor import doctor  # noqa: E402  (the bring-up checklist)

main.add_command(doctor)
main.add_command(flash)
main.add_command(monitor)
main.add_command(run)

main.add_command(_verify.new)
main.add_command(_verify.verify)


if __name__ == "__main__":  # pragma: no cover
    main()
