"""``esair std``: the STD command group, mounted in esair_min's ``esair`` command.

Each concern adds its commands from its own module (deploy: check, schema). Only the
CLI turns errors into exit status 1 and one ``error: ...`` line (:func:`friendly`).
"""

from __future__ import annotations

import sys
from functools import wraps
from typing import Any, Callable

import click

from esair_min.errors import EsairError


def friendly(fn: Callable[..., Any]) -> Callable[..., Any]:
    """Run ``fn``; an EsairError becomes one line on stderr and exit status 1."""

    @wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return fn(*args, **kwargs)
        except EsairError as exc:
            click.echo(f"error: {exc}", err=True)
            sys.exit(1)

    return wrapper


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
def std() -> None:
    """ESAIR STD: the host runtime. Deploy a robot's resources (drivers), behaviors
    and reactions from a deployment file (docs/std-deployment.md)."""


from . import deploy as _deploy  # noqa: E402  (registers its commands on std)

from . import control as _control  # noqa: E402
from . import run as _run  # noqa: E402
from . import top as _top  # noqa: E402

from . import agent as _agent  # noqa: E402  (many computers: docs/std-network.md)
from . import certs as _certs  # noqa: E402

for _cmd in [*_deploy.COMMANDS, _run.run_cmd, *_control.COMMANDS, _top.top_cmd,
             _agent.agent_cmd, _certs.certs]:
    std.add_command(_cmd)
