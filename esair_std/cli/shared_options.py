"""Options several ``esair std`` commands share, checked by click (a bad value is a
usage error: exit status 2)."""

from __future__ import annotations

from typing import Callable, TypeVar

import click

from ..endpoint import endpoint_fault

_F = TypeVar("_F", bound=Callable[..., object])     # a click command's function


def check_endpoint(_ctx: click.Context, _param: click.Parameter,
                   value: str | None) -> str | None:
    """``-e``: the form a deployment's ``endpoint`` has (the same checks and words)."""
    if value is None:
        return None
    fault = endpoint_fault(value)
    if fault is not None:
        raise click.BadParameter(fault.removeprefix("'endpoint' "))
    return value


def endpoint_option(help_text: str) -> Callable[[_F], _F]:
    """``-e/--endpoint``, by default $ESAIR_STD_ENDPOINT."""
    return click.option("-e", "--endpoint", default=None, metavar="tcp/HOST:PORT",
                        envvar="ESAIR_STD_ENDPOINT", show_envvar=True,
                        callback=check_endpoint, help=help_text)


def insecure_option() -> Callable[[_F], _F]:
    """``--insecure``: run on an address other computers reach without security."""
    return click.option("--insecure", is_flag=True,
                        help="Allow an address other computers reach without security "
                             "(prints a warning): anyone on the network could command the "
                             "robot.")


def exposure(where: str, needs: str, insecure: bool) -> None:
    """``where`` (``listening on tcp/0.0.0.0:7447``) reaches other computers without
    security: refused, naming what it ``needs``, unless ``--insecure`` (then a warning
    on stderr). The one wording of ``esair std run``, ``agent`` and ``hmi``."""
    from ..errors import ControlError
    if not insecure:
        raise ControlError(f"{where} reaches other computers: it needs {needs}, or "
                           "--insecure to go without")
    click.echo(f"warning: {where} without security (--insecure): anyone on the network "
               "can reach the robot", err=True)
