"""``esair std ls/add/remove/add-resource/remove-resource/put/get/configure/reaction/
inspect``: run-time control of a running robot from another terminal, over its control
endpoint (``-e``, default tcp/127.0.0.1:7447 or $ESAIR_STD_ENDPOINT)."""

from __future__ import annotations

import functools
import json
import sys
from typing import IO, TYPE_CHECKING, Any, Callable, Protocol

import click

from ..errors import ControlError
from ..transport.codec import JSON, JSONObject
from esair_min.cli.pipes import friendly

from .jsontext import json_or_text, option_value
from .shared_options import endpoint_option
from .table import table as _table

if TYPE_CHECKING:  # pragma: no cover
    from .client import Client

ENDPOINT = endpoint_option("The runtime's control endpoint (default: $ESAIR_STD_ENDPOINT, "
                           "else tcp/127.0.0.1:7447).")
ROBOT = click.option("-r", "--robot", default=None,
                     help="The robot's name (default: the one runtime answering).")


#: The most DATA one put carries: the message cap less room for the request around it.
MAX_DATA = 256 * 1024 - 1024


class Caller(Protocol):
    """What asks the runtime a control verb: the control client, or the runtime itself
    (``esair std run``'s live table)."""

    def call(self, verb: str, body: JSONObject | None = None) -> Any: ...   # its answer


class _Connection:
    """The runtime's control client, connected when a command first uses it: a command
    checks its arguments (a JSON typo, a bad pair) before it connects."""

    def __init__(self, endpoint: str | None, robot: str | None):
        self._args = (endpoint, robot)
        self._client: Client | None = None

    def _connected(self) -> Client:
        if self._client is None:
            from .client import Client
            self._client = Client(*self._args)
        return self._client

    def call(self, verb: str, body: JSONObject | None = None,
             timeout: float | None = None) -> Any:             # the answer, read as told
        return self._connected().call(verb, body, timeout)

    @property
    def robot(self) -> str:
        return self._connected().robot

    @property
    def endpoint(self) -> str:
        return self._connected().endpoint

    def close(self) -> None:
        if self._client is not None:
            self._client.close()


def control(fn: Callable[..., None]) -> Callable[..., None]:
    """Give ``fn`` the runtime's control client (connected at its first use) as its first
    argument."""

    @ENDPOINT
    @ROBOT
    @functools.wraps(fn)
    def wrapper(endpoint: str | None, robot: str | None, **kw: object) -> None:
        c = _Connection(endpoint, robot)
        try:
            return fn(c, **kw)
        finally:
            c.close()
    return friendly(wrapper)


TEXT = click.option("--text", "as_text", is_flag=True,
                    help="Send it as text (a string) as it is, never read as JSON.")


def value(text: str, what: str, as_text: bool = False) -> JSON:
    """JSON or text (jsontext.json_or_text); with --text, the text itself."""
    return text if as_text else json_or_text(text, what)


def options_of(items: tuple[str, ...]) -> JSONObject:
    """``-o KEY=VALUE ...`` as a dict, each VALUE JSON or text."""
    return {k: option_value(k, v) for k, v in pairs(items, "option").items()}


def pairs(items: tuple[str, ...], what: str) -> dict[str, str]:
    out = {}
    for item in items:
        k, sep, v = item.partition("=")
        if not sep or not k:
            raise ControlError(f"{what} {item!r} is not of the form NAME=VALUE")
        out[k] = v
    return out


@click.command("ls")
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
@control
def ls_cmd(c: _Connection, as_json: bool) -> None:
    """List components: name, kind, state, pid, host, restarts, reason (a driver's row
    before its children's). --json: {"robot", "endpoint", "components": [...]}, every
    component with the keys name, kind, state, pid, host, restarts, reason, class,
    parent and attached (docs/std.md); "starting": true while the runtime still adds its
    deployment's components (the list then grows)."""
    rows = c.call("ls", {"all": True})
    ping = c.call("ping")
    starting = bool(ping.get("starting", False))
    if as_json:
        click.echo(json.dumps({"robot": c.robot, "endpoint": c.endpoint,
                               "starting": starting, "stopped": ping.get("stopped"),
                               "components": rows}, indent=1))
        return
    click.echo(_table(rows, ["name", "kind", "state", "pid", "host", "restarts", "reason"]))
    if ping.get("stopped"):
        click.echo(stopped_line(ping["stopped"]))
    if starting:
        click.echo(f"robot {c.robot!r} is still starting: more of its components may "
                   "be listed soon", err=True)


def stopped_line(state: JSON, lead: str = "") -> str:
    """``STOPPED by WHO at TIME (reason): release with esair std release``, or "" while
    not stopped (the latched STOP: docs/std.md)."""
    if not isinstance(state, dict):
        return ""
    why = f" ({state['reason']})" if state.get("reason") else ""
    return (f"{lead}STOPPED by {state.get('by')} at {state.get('at')}{why}: release with "
            f"esair std release")


def still_starting(c: _Connection) -> bool:
    """Whether the runtime still adds its deployment's components (ping's ``starting``;
    False from a runtime that does not say)."""
    return bool(c.call("ping").get("starting", False))


@click.command("add")
@click.argument("name")
@click.argument("class_path", metavar="module:Class")
@click.option("--uses", multiple=True, metavar="RES=LEVEL",
              help="A resource and the level it is used at (read, command, configure).")
@click.option("--period", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Seconds between steps.")
@click.option("-o", "--option", "options", multiple=True, metavar="KEY=VALUE",
              help="An option (self.options); VALUE is JSON or text (text that starts "
                   "with {, [ or \" as a JSON string).")
@control
def add_cmd(c: _Connection, name: str, class_path: str, uses: tuple[str, ...],
            period: float | None, options: tuple[str, ...]) -> None:
    """Add behavior NAME (module:Class, imported from the deployment's folder first)."""
    opts = options_of(options)
    state = c.call("add", {"name": name, "class": class_path, "uses": pairs(uses, "--uses"),
                           "period": period, "options": opts}, timeout=30)
    click.echo(f"{name}: {state}")


@click.command("remove")
@click.argument("name")
@control
def remove_cmd(c: _Connection, name: str) -> None:
    """Remove behavior (or reaction) NAME: it is stopped and its registrations end."""
    c.call("remove", {"name": name}, timeout=30)
    click.echo(f"{name}: removed")


@click.command("add-resource")
@click.argument("name")
@click.argument("class_path", metavar="module:Class")
@click.option("--allow", multiple=True, metavar="WHO=LEVEL",
              help="A behavior (or fnmatch pattern) and the highest level it may use.")
@click.option("-o", "--option", "options", multiple=True, metavar="KEY=VALUE",
              help="An option (self.options); VALUE is JSON or text (text that starts "
                   "with {, [ or \" as a JSON string).")
@control
def add_resource_cmd(c: _Connection, name: str, class_path: str, allow: tuple[str, ...],
                     options: tuple[str, ...]) -> None:
    """Add resource NAME (a Sensor, Actuator or Driver class) while the robot runs."""
    opts = options_of(options)
    kids = c.call("add-resource", {"name": name, "class": class_path,
                                   "allow": pairs(allow, "--allow"), "options": opts},
                  timeout=30)
    for child, kind in kids.items():
        click.echo(f"{child}: {kind} ready")


@click.command("remove-resource")
@click.argument("name")
@control
def remove_resource_cmd(c: _Connection, name: str) -> None:
    """Remove resource NAME at once; attached behaviors are told and keep running."""
    told = c.call("remove-resource", {"name": name}, timeout=30)
    click.echo(f"{name}: removed" + (f" (detached: {', '.join(told)})" if told else ""))


@click.command("put")
@click.argument("name")
@click.argument("data", required=False)
@click.option("-f", "--file", "file", type=click.File("r", encoding="utf-8"), default=None,
              metavar="FILE", help="Read DATA from FILE (- for standard input).")
@click.option("--timeout", type=click.FloatRange(0, 3600), default=1.0, show_default=True,
              help="Seconds to wait for the behavior.")
@click.option("--no-wait", is_flag=True,
              help="Done when the data is in the behavior's mailbox, before its receive() "
                   "ran (a refusal is then not reported here).")
@TEXT
@control
def put_cmd(c: _Connection, name: str, data: str | None, file: IO[str] | None, timeout: float,
            no_wait: bool, as_text: bool) -> None:
    """Deliver DATA (JSON, or text) to behavior NAME through the BS, as `operator`, and
    wait until its receive() took it: a behavior refuses data by raising
    esair_std.Refused("why") there, and the refusal is the error printed. DATA that
    starts like JSON ({, [ or ") must be JSON (--text sends it as text). DATA `-` (or
    --file FILE) reads it from standard input (or FILE): data too long for the command
    line, at most 255 KiB of JSON (one message)."""
    if (data is None) == (file is None):
        raise click.UsageError("give DATA, or --file FILE, not both" if data is not None
                               else "give DATA (or - for standard input), or --file FILE")
    if data == "-":
        data = sys.stdin.read()
    elif data is None:                   # then FILE was given (checked above)
        assert file is not None
        data = file.read()
    obj = value(data, "DATA" if file is None else f"DATA in {file.name}", as_text)
    size = len(json.dumps(obj, separators=(",", ":")).encode())     # as the wire has it
    if size > MAX_DATA:
        raise ControlError(f"DATA is {size} bytes of JSON, more than one message carries "
                           f"({MAX_DATA} bytes)")
    r = c.call("put", {"to": name, "data": obj, "timeout": timeout,
                       "wait": not no_wait}, timeout=timeout + 5)
    if not r["delivered"]:
        raise ControlError(f"put to {name!r} failed: {r['reason']}")
    click.echo("delivered")


@click.command("get")
@click.argument("name")
@click.option("--timeout", type=click.FloatRange(0, 3600), default=1.0, show_default=True,
              help="Seconds to wait for the behavior.")
@control
def get_cmd(c: _Connection, name: str, timeout: float) -> None:
    """Ask behavior NAME for data (its provide()) through the BS; print it as JSON."""
    r = c.call("get", {"to": name, "timeout": timeout}, timeout=timeout + 5)
    if not r["ok"]:
        kind = c.call("kind", {"resource": name}) if r["reason"].startswith(
            "no behavior") else None
        hint = {"sensor": f" (a sensor: read it with `esair std sample {name}`)",
                "actuator": f" (an actuator: command it with `esair std send {name} VALUE`)"
                }.get(kind or "", "")
        raise ControlError(f"get from {name!r} failed: {r['reason']}{hint}")
    click.echo(json.dumps(r["data"]))


@click.command("sample")
@click.argument("name")
@click.option("--timeout", type=click.FloatRange(0, 3600), default=2.0, show_default=True,
              help="Seconds to wait for a first sample.")
@click.option("--meta", is_flag=True, help="Print {resource, seq, t, value}, not the value.")
@control
def sample_cmd(c: _Connection, name: str, timeout: float, meta: bool) -> None:
    """Print the latest sample of sensor NAME as JSON (e.g. papaman.feet)."""
    s = c.call("sample", {"name": name, "timeout": timeout}, timeout=timeout + 5)
    click.echo(json.dumps(s if meta else s["value"]))


@click.command("send")
@click.argument("name")
@click.argument("val", metavar="VALUE")
@click.option("--timeout", type=click.FloatRange(0, 3600), default=1.0, show_default=True,
              help="Seconds the actuator may take.")
@TEXT
@control
def send_cmd(c: _Connection, name: str, val: str, timeout: float, as_text: bool) -> None:
    """Send one command VALUE (JSON, or text) to actuator NAME as the operator; print the
    actuator's answer. Refused unless its resource's allow grants `operator: command`.
    VALUE that starts like JSON ({, [ or ") must be JSON (--text sends it as text)."""
    command = value(val, "VALUE", as_text)
    click.echo(json.dumps(c.call("send", {"name": name, "value": command,
                                          "timeout": timeout}, timeout=timeout + 5)))


@click.command("configure")
@click.argument("resource")
@click.argument("key")
@click.argument("val", metavar="VALUE")
@TEXT
@control
def configure_cmd(c: _Connection, resource: str, key: str, val: str, as_text: bool) -> None:
    """Set KEY of RESOURCE to VALUE (JSON or text), as the operator. VALUE that starts
    like JSON ({, [ or ") must be JSON (--text sends it as text)."""
    setting = value(val, "VALUE", as_text)
    click.echo(json.dumps(c.call("configure", {"resource": resource, "key": key,
                                               "value": setting})))


@click.command("reaction")
@click.argument("name")
@click.argument("action", type=click.Choice(["enable", "disable"]))
@control
def reaction_cmd(c: _Connection, name: str, action: str) -> None:
    """Enable or disable reaction NAME."""
    c.call("reaction", {"name": name, "enabled": action == "enable"})
    click.echo(f"{name}: {action}d")


@click.command("inspect")
@click.argument("name")
@control
def inspect_cmd(c: _Connection, name: str) -> None:
    """A component's state and counters, as JSON."""
    click.echo(json.dumps(c.call("inspect", {"name": name}), indent=1))


@click.command("stop")
@click.option("--reason", default="", metavar="TEXT", help="Why (shown with the state).")
@control
def stop_cmd(c: _Connection, reason: str) -> None:
    """STOP the robot, latched: every motion stopped at once, every queued actuator
    command dropped, every new one refused (behaviors, reactions, remote agents, `esair
    std send`, the HMI) until `esair std release`. Sensors and behaviors go on."""
    state = c.call("stop", {"reason": reason}, timeout=10)
    click.echo(stopped_line(state))


@click.command("release")
@control
def release_cmd(c: _Connection) -> None:
    """Release the STOP (an operator's deliberate act): actuator commands are taken
    again. It starts nothing by itself."""
    was = c.call("release", {}, timeout=10)
    click.echo(f"released (stopped by {was.get('by')} at {was.get('at')})")


@click.command("ping")
@control
def ping_cmd(c: _Connection) -> None:
    """The runtime answering: robot, mode, pid, whether it still starts, and whether it
    is STOPPED (by whom, when)."""
    p = c.call("ping")
    click.echo(f"robot {p['robot']} ({p['mode']} mode, pid {p['pid']})"
               + (", starting" if p.get("starting") else "") + ": "
               + (stopped_line(p.get("stopped")) or "running"))


COMMANDS = [ls_cmd, add_cmd, remove_cmd, add_resource_cmd, remove_resource_cmd, put_cmd,
            get_cmd, sample_cmd, send_cmd, configure_cmd, reaction_cmd, inspect_cmd,
            stop_cmd, release_cmd, ping_cmd]
