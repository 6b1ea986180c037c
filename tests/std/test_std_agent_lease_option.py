"""``esair std agent --lease MS``: an agent's link lease (when the control center drops
it after a cut, docs/std-network.md "When `lost` comes") can be set without TLS or a
login too (before, only a security section carried it, so a plain agent always had
2 s). The control center learns it from the join; a bad value is refused."""

from __future__ import annotations

import subprocess
import sys

import pytest
from click.testing import CliRunner

from esair_std import Runtime
from esair_std.cli.agent import agent_cmd
from tests.support.std import ROOT, free_endpoint, wait_for


@pytest.fixture(scope="module")
def center():
    rt = Runtime({"robot": "lab", "behaviors": {"idle": {"class": "tests.support.comps:Sink"}}},
                 mode="process", endpoint=free_endpoint())
    rt.start()
    try:
        yield rt
    finally:
        rt.stop()


@pytest.mark.parametrize("args, lease", [(["--lease", "5000"], 5.0), ([], 2.0)])
def test_a_plain_agent_declares_the_lease_it_is_given(center, args, lease):
    name = f"far{int(lease)}"
    proc = subprocess.Popen([sys.executable, "-m", "esair_min.cli", "std", "agent", "--connect",
                             center.endpoint, name, "tests.support.comps:Sink", *args],
                            cwd=ROOT, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    try:
        wait_for(lambda: center.state(name) == "running", 60, what=f"{name} running")
        assert center.mode.remote[name]["lease"] == lease
    finally:
        proc.terminate()
        out, _ = proc.communicate(timeout=30)
    assert proc.returncode == 0, out


@pytest.mark.parametrize("value, why", [
    ("100", "100 is not in the range 200<=x<=60000."),
    ("60001", "60001 is not in the range 200<=x<=60000."),
    ("x", "'x' is not a valid integer range."),
])
def test_a_bad_lease_is_refused(value, why):
    out = CliRunner().invoke(agent_cmd, ["--connect", "tcp/127.0.0.1:9", "x",
                                         "bench.toolkit.netcomps:Strict", "--lease", value])
    assert out.exit_code == 2, out.output
    assert out.output.strip().splitlines()[-1] == f"Error: Invalid value for '--lease': {why}"
