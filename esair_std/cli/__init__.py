"""``esair std``: the STD command group, mounted in esair_min's ``esair`` command.

Each concern adds its commands from its own module (deploy: check, schema). Only the
CLI turns errors into exit status 1 and one ``error: ...`` line (:func:`friendly`).
"""

from __future__ import annotations

import click

from esair_min.cli.pipes import friendly  # noqa: F401  (the commands' error wrapper)


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
from . import hmi as _hmi  # noqa: E402  (the remote control center: docs/hmi.md)

for _cmd in [*_deploy.COMMANDS, _run.run_cmd, *_control.COMMANDS, _top.top_cmd,
             _agent.agent_cmd, _certs.certs, *_hmi.COMMANDS]:
    std.add_command(_cmd)
