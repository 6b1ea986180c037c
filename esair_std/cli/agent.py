"""``esair std agent``: run a behavior or a resource on this computer as a remote agent of
a robot's control center (docs/std-network.md)."""

from __future__ import annotations

import json
import logging
import os
import sys

import click

from esair_min.cli.pipes import friendly

from ..endpoint import reaches_beyond
from .jsontext import option_value
from .shared_options import exposure, insecure_option


def _pairs(items: tuple[str, ...], what: str) -> dict[str, str]:
    out = {}
    for item in items:
        key, sep, val = item.partition("=")
        if not sep or not key or not val:
            raise click.BadParameter(f"{item!r} is not of the form NAME=LEVEL", param_hint=what)
        out[key] = val
    return out


def _restart_policy(text: str | None, kind: str) -> tuple[int, float]:
    """``--restart MAX/WITHIN`` as (max, within); (0, 0) when not given."""
    if text is None:
        return (0, 0.0)
    if kind != "behavior":
        raise click.BadParameter("a remote resource is restarted by whatever runs its agent "
                                 "(it exits with status 1 when it fails)",
                                 param_hint="--restart")
    most, sep, within = text.partition("/")
    try:
        policy = (int(most), float(within))
    except ValueError:
        policy = (-1, -1.0)
    if not sep or policy[0] < 1 or policy[1] <= 0:
        raise click.BadParameter(f"{text!r} is not MAX/WITHIN (e.g. 3/60: at most 3 restarts "
                                 "in any 60 s)", param_hint="--restart")
    return policy


@click.command("agent")
@click.option("--connect", "endpoint", required=True, metavar="tcp/HOST:PORT",
              help="The control center's endpoint (tls/HOST:PORT when it requires TLS).")
@click.argument("name")
@click.argument("class_path", metavar="module:Class")
@click.option("--uses", multiple=True, metavar="RESOURCE=LEVEL",
              help="A resource the behavior registers for (read, command, configure); repeat.")
@click.option("--allow", multiple=True, metavar="BEHAVIOR=LEVEL",
              help="For a sensor/actuator/driver: who may use it, up to which level; repeat.")
@click.option("--period", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Seconds between step() calls.")
@click.option("-o", "--option", "options", multiple=True, metavar="KEY=VALUE",
              help="An option for the component (self.options; VALUE is JSON or text, text that "
                   "starts with {, [ or \" as a JSON string).")
@click.option("--robot", default=None, help="The robot's name (found by asking when not given).")
@click.option("--ca", type=click.Path(dir_okay=False), help="CA certificate (TLS).")
@click.option("--cert", type=click.Path(dir_okay=False), help="This agent's certificate (mTLS).")
@click.option("--key", type=click.Path(dir_okay=False), help="This agent's private key (mTLS).")
@click.option("--user", default=None, help="Login name (user/password authentication).")
@click.option("--password-file", type=click.Path(dir_okay=False),
              help="File holding the password of --user.")
@click.option("--lease", "lease_ms", type=click.IntRange(200, 60000), default=None, metavar="MS",
              help="This agent's link lease: the control center drops it after MS of "
                   "silence (default 2000), with or without TLS.")
@click.option("--host-name", default=None, help="The name `esair std ls` shows for this "
                                                "computer (default: its hostname).")
@click.option("--restart", default=None, metavar="MAX/WITHIN",
              help="A behavior's restart policy, as restart: {max, within} in a deployment: "
                   "restarted by this agent at most MAX times in any WITHIN seconds "
                   "(default: never).")
@insecure_option()
@friendly
def agent_cmd(endpoint: str, name: str, class_path: str, uses: tuple[str, ...],
              allow: tuple[str, ...], period: float | None, options: tuple[str, ...],
              robot: str | None, ca: str | None, cert: str | None, key: str | None,
              user: str | None, password_file: str | None, lease_ms: int | None,
              host_name: str | None, restart: str | None, insecure: bool) -> None:
    """Run NAME (a Behavior, Sensor, Actuator or Driver class module:Class, imported from
    the current folder first) here, as an agent of the control center at --connect.

    It joins the control center (its identity checked when the robot lists its agents),
    registers like a local component and stays until told to stop (Ctrl-C, `esair std
    remove NAME`). When the link is lost it keeps running and joins again by itself
    when the link returns."""
    from pydantic import ValidationError

    from ..behavior import Behavior
    from ..errors import ControlError
    from ..resource import Actuator, Driver, Sensor
    from ..classes import component_class
    from ..transport.security_config import SecuritySpec

    logging.basicConfig(level=logging.WARNING, format="%(name)s: %(message)s")
    cls = component_class(class_path, os.getcwd())
    if isinstance(cls, type) and issubclass(cls, Behavior):
        kind = "behavior"
    elif isinstance(cls, type) and issubclass(cls, (Sensor, Actuator, Driver)):
        kind = "resource"
    else:
        raise click.BadParameter(f"{class_path} is not a Behavior, Sensor, Actuator or Driver",
                                 param_hint="module:Class")
    policy = _restart_policy(restart, kind)
    if reaches_beyond(endpoint) and not (endpoint.startswith(("tls/", "quic/")) or user):
        exposure(f"connecting to {endpoint}", "TLS (a tls/ endpoint, --ca and --cert) or a "
                 "login (--user, --password-file)", insecure)
    sec = None
    if any((ca, cert, key, user, password_file)) or lease_ms is not None:
        lease = {} if lease_ms is None else {"lease_ms": lease_ms}
        try:
            sec = SecuritySpec(ca=ca, cert=cert, key=key, user=user,
                               password_file=password_file, mtls=cert is not None, **lease)
        except ValidationError as exc:
            raise ControlError(exc.errors()[0]["msg"].removeprefix("Value error, ")) from None
    opts = {k: option_value(k, v) for k, v in _pairs(options, "--option").items()}
    if kind == "resource":
        opts_spec = {"allow": _pairs(allow, "--allow")}
    else:
        opts_spec = {"uses": _pairs(uses, "--uses")}
    kw = dict(endpoint=endpoint, name=name, class_path=class_path, kind=kind, period=period,
              options=opts, robot=robot, hostname=host_name, log="WARNING", **opts_spec,
              restart=policy,
              sec=sec.model_dump(mode="json") if sec is not None else None)
    sys.stdout.flush()
    sys.stderr.flush()
    # options checked: become the lean agent process (no click, pydantic, yaml in it)
    os.execv(sys.executable, [sys.executable, "-m", "esair_std.remote.remote_agent", json.dumps(kw)])
