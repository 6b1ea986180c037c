"""The help of `esair std new` and `esair std check` names every bundled example
deployment (it named papaman and lab while starfish was bundled too, and a user
reading `esair std new --help` did not learn that `esair std new starfish DIR` works);
every option of every `esair` command says what it does (`esair std replay --speed`
and its `--endpoint` default said nothing)."""

from __future__ import annotations

import click
import pytest
from click.testing import CliRunner

from esair_min.cli import main
from esair_std.cli import std
from esair_std.deploy.bundled import bundled_examples


def test_the_bundled_examples_are_these():
    assert bundled_examples() == ["lab", "papaman", "starfish"]


@pytest.mark.parametrize("command", ["new", "check"])
def test_the_help_names_every_bundled_example(command):
    out = CliRunner().invoke(std, [command, "--help"], terminal_width=200)
    assert out.exit_code == 0, out.output
    assert "bundled example" in out.output
    assert f"({', '.join(bundled_examples())})" in " ".join(out.output.split())


def commands(group: click.Group, path: str) -> list[tuple[str, click.Command]]:
    ctx = click.Context(group)
    found: list[tuple[str, click.Command]] = []
    for name in group.list_commands(ctx):
        cmd = group.get_command(ctx, name)
        assert cmd is not None
        found += (commands(cmd, f"{path} {name}") if isinstance(cmd, click.Group)
                  else [(f"{path} {name}", cmd)])
    return found


def test_every_option_of_every_command_has_a_help_text():
    found = commands(main, "esair")
    assert {"esair emulate", "esair std run", "esair std replay", "esair std agent"} <= {
        p for p, _ in found}
    assert [(p, o.opts) for p, c in found for o in c.params
            if isinstance(o, click.Option) and not o.help] == []
    assert [p for p, c in found if not c.help] == []
    assert "--endpoint tcp/HOST:PORT The runtime's control endpoint (default tcp/127.0.0.1:7447, " \
        "or $ESAIR_STD_ENDPOINT)." in " ".join(CliRunner().invoke(
            std, ["replay", "--help"], terminal_width=200).output.split())
