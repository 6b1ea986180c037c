"""The help of `esair std new` and `esair std check` names every bundled example
deployment (it named papaman and lab while starfish was bundled too, and a user
reading `esair std new --help` did not learn that `esair std new starfish DIR` works)."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

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
