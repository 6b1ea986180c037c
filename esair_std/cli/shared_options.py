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


def server_options(default_listen: str, listen_help: str,
                   client_ca_help: str) -> Callable[[_F], _F]:
    """``-e``, ``--listen``, ``--tls-cert``, ``--tls-key``, ``--client-ca`` and
    ``--insecure`` of a server others connect to (``esair std hmi``, ``foxglove``; what
    they do with them: serving.py)."""
    options = [
        endpoint_option("The runtime's control endpoint (default tcp/127.0.0.1:7447)."),
        click.option("--listen", default=default_listen, show_default=True, metavar="HOST:PORT",
                     help=listen_help + " Port 0: any free port."),
        click.option("--tls-cert", default=None, metavar="PEM", help="Serve over TLS (https://, "
                     "wss://) with this certificate (e.g. from `esair std certs`)."),
        click.option("--tls-key", default=None, metavar="PEM", help="Its private key."),
        click.option("--client-ca", default=None, metavar="PEM",
                     help=client_ca_help),
        insecure_option()]

    def decorate(f: _F) -> _F:
        for option in reversed(options):
            f = option(f)
        return f
    return decorate
