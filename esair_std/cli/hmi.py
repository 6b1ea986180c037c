"""``esair std hmi``: the remote control center in a browser (docs/hmi.md), and
``esair std hmi-password`` to write its password file."""

from __future__ import annotations

import getpass
import os
import signal
import sys

import click

from esair_min import sigs
from esair_min.cli.pipes import friendly

from ..plurals import counted
from .client import default_endpoint
from .shared_options import exposure, server_options

DEFAULT_LISTEN = "127.0.0.1:8080"


@click.command("hmi")
@server_options(DEFAULT_LISTEN, "Where the page is served. Any address but loopback needs a "
                "login or client certificates.",
                "Require browser certificates signed by this CA; such pages are operators.")
@click.option("--password-file", default=None, metavar="FILE",
              help="USER:HASH lines (`esair std hmi-password`): pages are viewers until "
                   "they log in. $ESAIR_HMI_PASSWORD gives user 'operator' a password.")
@click.option("--record-dir", default=".", show_default=True, type=click.Path(file_okay=False),
              help="Where the page's record button writes its MCAP files (and replay reads).")
@friendly
def hmi_cmd(endpoint: str | None, listen: str, tls_cert: str | None, tls_key: str | None,
            client_ca: str | None, insecure: bool, password_file: str | None,
            record_dir: str) -> None:
    """Serve the robot's remote control center: live link state, pose, joints,
    feet, components and log in a browser; commands through the RS as principal
    `hmi` (the deployment's `allow` decides what it may command). Prints the URL on
    its first line and serves until Ctrl-C."""
    from ..hmi.auth import LOOPBACK, Auth
    from ..hmi.server import HmiServer
    from .serving import quiet_logs, serve, split_listen, tls_context

    host, port = split_listen(listen, DEFAULT_LISTEN)
    tls = tls_context(tls_cert, tls_key, client_ca)
    auth = Auth.from_options(host, password_file, dict(os.environ),
                             client_certs=bool(client_ca), insecure=insecure)
    if insecure and auth.open and host not in LOOPBACK:
        exposure(f"listening on {host}", "", insecure)     # the warning
    os.environ.pop("ESAIR_HMI_PASSWORD", None)      # hashed in auth; not kept in the clear
    quiet_logs("hmi")
    serve(HmiServer(endpoint or default_endpoint(), host, port, auth, tls,
                    record_dir=record_dir).serve)


@click.command("hmi-password")
@click.argument("file", type=click.Path(dir_okay=False))
@click.argument("user")
@friendly
def hmi_password_cmd(file: str, user: str) -> None:
    """Add USER with a password (asked for, or read from standard input) to FILE, hashed
    (scrypt); `esair std hmi --password-file FILE` then asks pages to log in."""
    from ..errors import ControlError
    from ..hmi.auth import hash_password, read_password_file
    if ":" in user or not user.strip():
        raise ControlError(f"user {user!r} must be a non-empty name without ':'")
    users = read_password_file(file) if os.path.exists(file) else {}
    password = (getpass.getpass(f"password for {user}: ") if sys.stdin.isatty()
                else sys.stdin.readline().rstrip("\n"))
    if not password:
        raise ControlError("empty password")
    users[user] = hash_password(password)
    fd = os.open(file, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "w") as f:
        f.writelines(f"{u}:{h}\n" for u, h in users.items())
    click.echo(f"{user}: written to {file}")


COMMANDS = [hmi_cmd, hmi_password_cmd]


@click.command("record")
@click.argument("out", metavar="OUT.mcap", type=click.Path(dir_okay=False))
@click.argument("names", nargs=-1, metavar="[NAMES]...")
@click.option("-e", "--endpoint", default=None, metavar="tcp/HOST:PORT",
              help="The runtime's control endpoint (default tcp/127.0.0.1:7447, or "
                   "$ESAIR_STD_ENDPOINT).")
@click.option("--seconds", type=click.FloatRange(min=0), default=None,
              help="Record this long, then stop (default: until Ctrl-C).")
@friendly
def record_cmd(out: str, names: tuple[str, ...], endpoint: str | None,
               seconds: float | None) -> None:
    """Record every sample of the sensors NAMES (fnmatch patterns; default: all) and
    every command the actuators NAMES run (with its outcome) to OUT.mcap (JSON messages
    with a JSON schema: Foxglove, Lichtblick and PlotJuggler open it), as the principal
    `record` (read, as the deployment's `allow` permits)."""
    import threading

    from ..record import Recorder
    rec = Recorder(endpoint or default_endpoint(), out, list(names))
    stop = threading.Event()
    sigs.install(signal.SIGTERM, lambda *_: stop.set())
    sigs.install(signal.SIGINT, lambda *_: stop.set())
    rec.start()
    click.echo(f"recording to {out}", err=True)
    sigs.wait(stop, seconds)        # a signal taken by any thread ends it
    c = rec.stop()
    click.echo(f"{out}: {counted(c['written'], 'sample')} and "
               f"{counted(c['commands'], 'command')} on {counted(c['channels'], 'channel')}, "
               f"{c['dropped']} dropped, {c['gaps'] + c['command_gaps']} gaps in seq", err=True)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)


@click.command("replay")
@click.argument("file", metavar="FILE.mcap", type=click.Path(exists=True, dir_okay=False))
@click.option("-e", "--endpoint", default=None, metavar="tcp/HOST:PORT",
              help="The runtime's control endpoint (default tcp/127.0.0.1:7447, or "
                   "$ESAIR_STD_ENDPOINT).")
@click.option("--name", default="replay", show_default=True,
              help="The resource entry: its sensors are NAME.<recorded sensor>.")
@click.option("--speed", type=click.FloatRange(min=0, min_open=True), default=1.0,
              show_default=True, help="Pace: 2 plays the recording twice as fast.")
@click.option("--loop", is_flag=True, help="Start again at the end.")
@friendly
def replay_cmd(file: str, endpoint: str | None, name: str, speed: float, loop: bool) -> None:
    """Publish a recording as sensors of the running robot (a resource entry added
    through the RS; `esair std remove-resource NAME` ends it)."""
    from .client import Client
    with Client(endpoint) as c:
        kids = c.call("add-resource", {"name": name, "class": "esair_std.record.replay:Replay",
                                       "allow": {"*": "read"},
                                       "options": {"file": os.path.abspath(file),
                                                   "speed": speed, "loop": loop}}, timeout=30)
    for child, kind in kids.items():
        click.echo(f"{child}: {kind} ready")


COMMANDS += [record_cmd, replay_cmd]
