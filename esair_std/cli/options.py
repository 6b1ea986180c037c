"""Options several ``esair std`` commands share, checked by click (a bad value is a
usage error: exit status 2)."""

from __future__ import annotations

from typing import Any

import click

from ..endpoint import endpoint_fault


def check_endpoint(_ctx: Any, _param: Any, value: str | None) -> str | None:
    """``-e``: the form a deployment's ``endpoint`` has (the same checks and words)."""
    if value is None:
        return None
    fault = endpoint_fault(value)
    if fault is not None:
        raise click.BadParameter(fault.removeprefix("'endpoint' "))
    return value


def endpoint_option(help_text: str) -> Any:
    """``-e/--endpoint``, by default $ESAIR_STD_ENDPOINT."""
    return click.option("-e", "--endpoint", default=None, metavar="tcp/HOST:PORT",
                        envvar="ESAIR_STD_ENDPOINT", show_envvar=True,
                        callback=check_endpoint, help=help_text)
