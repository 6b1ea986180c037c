"""``esair std``: the STD command group, mounted in esair_min's ``esair`` command.

Each concern adds its commands from its own module (deploy: check, schema). Only the
CLI turns errors into exit status 1 and one ``error: ...`` line (:func:`friendly`).

A command's module is imported only when that command runs (:data:`LAZY`): ``esair
std ls`` does not import the HMI's web server, the runtime or the certificate tools.
``--help`` imports them all, for their one-line help.
"""

from __future__ import annotations

import importlib

import click

from esair_min.cli.pipes import friendly  # noqa: F401  (the commands' error wrapper)

#: command name -> "module:attribute" of its click command, in the order --help lists
#: them (tests/std/test_std_cli_lazy.py holds it equal to what the modules define)
LAZY: dict[str, str] = {
    "check": "deploy:check", "schema": "deploy:schema", "new": "deploy:new",
    "run": "run:run_cmd",
    "ls": "control:ls_cmd", "add": "control:add_cmd", "remove": "control:remove_cmd",
    "add-resource": "control:add_resource_cmd",
    "remove-resource": "control:remove_resource_cmd", "put": "control:put_cmd",
    "get": "control:get_cmd", "sample": "control:sample_cmd", "send": "control:send_cmd",
    "configure": "control:configure_cmd", "reaction": "control:reaction_cmd",
    "inspect": "control:inspect_cmd",
    "stop": "control:stop_cmd", "release": "control:release_cmd",     # the latched STOP
    "ping": "control:ping_cmd",
    "top": "top:top_cmd",
    "agent": "agent:agent_cmd",                 # many computers: docs/std-network.md
    "certs": "certs:certs",
    "hmi": "hmi:hmi_cmd", "hmi-password": "hmi:hmi_password_cmd",   # docs/hmi.md
    "record": "hmi:record_cmd", "replay": "hmi:replay_cmd",
    "foxglove": "foxglove:foxglove_cmd",        # docs/foxglove.md
}


class _Lazy(click.Group):
    """The ``std`` group: each command imported from :data:`LAZY` when first asked."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return list(LAZY)

    def get_command(self, ctx: click.Context, name: str) -> click.Command | None:
        if name not in self.commands and name in LAZY:
            module, attr = LAZY[name].split(":")
            self.add_command(getattr(importlib.import_module(f"{__name__}.{module}"), attr),
                             name)
        return self.commands.get(name)


@click.group(cls=_Lazy, context_settings={"help_option_names": ["-h", "--help"]})
def std() -> None:
    """ESAIR STD: the host runtime. Deploy a robot's resources (drivers), behaviors
    and reactions from a deployment file (docs/std-deployment.md)."""
