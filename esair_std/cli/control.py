"""``esair std ls/add/remove/add-resource/remove-resource/put/get/configure/reaction/
inspect``: run-time control of a running robot from another terminal, over its control
endpoint (``-e``, default tcp/127.0.0.1:7447 or $ESAIR_STD_ENDPOINT)."""

from __future__ import annotations

import functools
import json
from typing import Any, Callable

import click

from ..errors import ControlError
from esair_min.cli.pipes import friendly
from .table import table as _table

ENDPOINT = click.option("-e", "--endpoint", default=None, metavar="tcp/HOST:PORT",
                        help="The runtime's control endpoint (default tcp/127.0.0.1:7447, "
                             "or $ESAIR_STD_ENDPOINT).")
ROBOT = click.option("-r", "--robot", default=None,
                     help="The robot's name (default: the one runtime answering).")


def control(fn: Callable[..., Any]) -> Callable[..., Any]:
    """Give ``fn`` a connected Client as its first argument."""

    @ENDPOINT
    @ROBOT
    @functools.wraps(fn)
    def wrapper(endpoint: str | None, robot: str | None, **kw: Any) -> Any:
        from .client import Client
        with Client(endpoint, robot) as c:
            return fn(c, **kw)
    return friendly(wrapper)


def value(text: str) -> Any:
    """JSON if it parses (1, 2.5, true, {"a": 1}, "s"), else the text itself."""
    try:
        return json.loads(text)
    except ValueError:
        return text


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
def ls_cmd(c: Any, as_json: bool) -> None:
    """List components: name, kind, state, pid, host."""
    rows = c.call("ls")
    if as_json:
        click.echo(json.dumps(rows, indent=1))
        return
    click.echo(_table(rows, ["name", "kind", "state", "pid", "host", "restarts", "reason"]))


@click.command("add")
@click.argument("name")
@click.argument("class_path", metavar="module:Class")
@click.option("--uses", multiple=True, metavar="RES=LEVEL",
              help="A resource and the level it is used at (read, command, configure).")
@click.option("--period", type=float, default=None, help="Seconds between steps.")
@click.option("-o", "--option", "options", multiple=True, metavar="KEY=VALUE",
              help="An option (self.options); VALUE is JSON or text.")
@control
def add_cmd(c: Any, name: str, class_path: str, uses: tuple, period: float | None,
            options: tuple) -> None:
    """Add behavior NAME (module:Class, imported from the deployment's folder first)."""
    opts = {k: value(v) for k, v in pairs(options, "option").items()}
    state = c.call("add", {"name": name, "class": class_path, "uses": pairs(uses, "--uses"),
                           "period": period, "options": opts}, timeout=30)
    click.echo(f"{name}: {state}")


@click.command("remove")
@click.argument("name")
@control
def remove_cmd(c: Any, name: str) -> None:
    """Remove behavior (or reaction) NAME: it is stopped and its registrations end."""
    c.call("remove", {"name": name}, timeout=30)
    click.echo(f"{name}: removed")


@click.command("add-resource")
@click.argument("name")
@click.argument("class_path", metavar="module:Class")
@click.option("--allow", multiple=True, metavar="WHO=LEVEL",
              help="A behavior (or fnmatch pattern) and the highest level it may use.")
@click.option("-o", "--option", "options", multiple=True, metavar="KEY=VALUE",
              help="An option (self.options); VALUE is JSON or text.")
@control
def add_resource_cmd(c: Any, name: str, class_path: str, allow: tuple, options: tuple) -> None:
    """Add resource NAME (a Sensor, Actuator or Driver class) while the robot runs."""
    opts = {k: value(v) for k, v in pairs(options, "option").items()}
    kids = c.call("add-resource", {"name": name, "class": class_path,
                                   "allow": pairs(allow, "--allow"), "options": opts},
                  timeout=30)
    for child, kind in kids.items():
        click.echo(f"{child}: {kind} ready")


@click.command("remove-resource")
@click.argument("name")
@control
def remove_resource_cmd(c: Any, name: str) -> None:
    """Remove resource NAME at once; attached behaviors are told and keep running."""
    told = c.call("remove-resource", {"name": name}, timeout=30)
    click.echo(f"{name}: removed" + (f" (detached: {', '.join(told)})" if told else ""))


@click.command("put")
@click.argument("name")
@click.argument("data")
@click.option("--timeout", type=float, default=1.0, show_default=True)
@control
def put_cmd(c: Any, name: str, data: str, timeout: float) -> None:
    """Deliver DATA (JSON, or text) to behavior NAME through the BS."""
    r = c.call("put", {"to": name, "data": value(data), "timeout": timeout},
               timeout=timeout + 5)
    if not r["delivered"]:
        raise ControlError(f"put to {name!r} failed: {r['reason']}")
    click.echo("delivered")


@click.command("get")
@click.argument("name")
@click.option("--timeout", type=float, default=1.0, show_default=True)
@control
def get_cmd(c: Any, name: str, timeout: float) -> None:
    """Ask behavior NAME for data (its provide()) through the BS; print it as JSON."""
    r = c.call("get", {"to": name, "timeout": timeout}, timeout=timeout + 5)
    if not r["ok"]:
        raise ControlError(f"get from {name!r} failed: {r['reason']}")
    click.echo(json.dumps(r["data"]))


@click.command("configure")
@click.argument("resource")
@click.argument("key")
@click.argument("val", metavar="VALUE")
@control
def configure_cmd(c: Any, resource: str, key: str, val: str) -> None:
    """Set KEY of RESOURCE to VALUE (JSON or text), as the operator."""
    click.echo(json.dumps(c.call("configure", {"resource": resource, "key": key,
                                               "value": value(val)})))


@click.command("reaction")
@click.argument("name")
@click.argument("action", type=click.Choice(["enable", "disable"]))
@control
def reaction_cmd(c: Any, name: str, action: str) -> None:
    """Enable or disable reaction NAME."""
    c.call("reaction", {"name": name, "enabled": action == "enable"})
    click.echo(f"{name}: {action}d")


@click.command("inspect")
@click.argument("name")
@control
def inspect_cmd(c: Any, name: str) -> None:
    """A component's state and counters, as JSON."""
    click.echo(json.dumps(c.call("inspect", {"name": name}), indent=1))


COMMANDS = [ls_cmd, add_cmd, remove_cmd, add_resource_cmd, remove_resource_cmd, put_cmd,
            get_cmd, configure_cmd, reaction_cmd, inspect_cmd]
