"""``esair std agent --restart MAX/WITHIN`` (issue 19.7): a bad policy is refused with a
clear error before the agent starts; a resource takes none (whatever runs its agent
restarts it: it exits with status 1 when it fails). The restart itself is tested across
two network namespaces (tests/net/test_std_net.py)."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from esair_std.cli.agent import agent_cmd


def _run(class_path: str, policy: str):
    return CliRunner().invoke(agent_cmd, ["--connect", "tcp/127.0.0.1:9", "x", class_path,
                                          "--restart", policy])


@pytest.mark.parametrize("policy", ["3", "0/60", "3/0", "a/b", "3/-1", "/"])
def test_a_bad_restart_policy_is_refused(policy):
    out = _run("bench.toolkit.netcomps:Strict", policy)
    assert out.exit_code == 2, out.output
    assert (f"Invalid value for --restart: {policy!r} is not MAX/WITHIN (e.g. 3/60: at "
            "most 3 restarts in any 60 s)") in " ".join(out.output.split())


def test_a_resource_takes_no_restart_policy():
    out = _run("bench.toolkit.netcomps:Wheel", "3/60")
    assert out.exit_code == 2, out.output
    assert ("Invalid value for --restart: a remote resource is restarted by whatever runs "
            "its agent (it exits with status 1 when it fails)") in " ".join(out.output.split())
