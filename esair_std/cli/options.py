"""Options several ``esair std`` commands share, checked by click (a bad value is a
usage error: exit status 2)."""

from __future__ import annotations

from typing import Any

import click


def check_endpoint(ctx: Any, param: Any, value: str | None) -> str | None:
    """``-e``: the form a deployment's ``endpoint`` has (the same checks and words)."""
    if value is None:
        return None
    from ..deploy.marks import dict_document
    from ..deploy.raw import check_endpoint as check
    from ..errors import DeployError
    try:
        check(value, dict_document({"endpoint": value}), ("endpoint",))
    except DeployError as exc:
        raise click.BadParameter(exc.message.removeprefix("'endpoint' ")) from None
    return value


def endpoint_option(help_text: str) -> Any:
    """``-e/--endpoint``, by default $ESAIR_STD_ENDPOINT."""
    return click.option("-e", "--endpoint", default=None, metavar="tcp/HOST:PORT",
                        envvar="ESAIR_STD_ENDPOINT", show_envvar=True,
                        callback=check_endpoint, help=help_text)
