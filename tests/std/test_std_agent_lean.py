"""A component process imports only what it needs (RSS per process, issue 11: <= 30 MB;
bench/std_goals.py measures it): none of the deployment loader's, the CLI's or error-only
modules, while it runs a sensor and a behavior attached to it. Process mode only: in
thread mode the components share the runtime's process, which loads the deployment."""

import pytest
import os
import subprocess
import sys
from pathlib import Path

from tests.support.std import agent_children, free_endpoint, wait_for
from esair_std import Runtime

pytestmark = pytest.mark.slow

HERE = Path(__file__).resolve().parents[2]  # the checkout: tests.support imports from here


def test_agent_processes_import_no_heavy_module():
    dep = {"robot": "t",
           "resources": {"count": {"class": "tests.support.lean_comps:Counting", "allow": {"*": "read"}}},
           "behaviors": {"listen": {"class": "tests.support.lean_comps:Listening",
                                    "uses": {"count": "read"}}}}
    rt = Runtime(dep, mode="process", endpoint=free_endpoint())
    rt.start()
    try:
        received, behavior_heavy = wait_for(
            lambda: (lambda r: r if r[0] > 0 else None)(rt.get("listen", timeout=2.0)),
            what="a sample at the behavior")
        sensor_heavy = rt.configure("count", "modules", 1)
        pids = {r["name"]: r["pid"] for r in rt.ls()}
    finally:
        rt.stop()
    assert agent_children() == [], "agent processes left behind"
    assert pids["listen"] != os.getpid() and pids["count"] != os.getpid()
    assert behavior_heavy == []
    assert sensor_heavy == []


def test_the_check_can_fail():
    """The same list in a process that loads a deployment: pydantic and yaml show."""
    code = ("import sys; from tests.support import lean_comps\n"
            "from esair_std.deploy import load_deployment\n"
            "load_deployment({'robot': 't'})\n"
            "print(' '.join(lean_comps.heavy_imported()))")
    out = subprocess.run([sys.executable, "-c", code], cwd=HERE, capture_output=True,
                         text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert {"pydantic", "yaml"} <= set(out.stdout.split())


def test_a_remote_agent_imports_no_heavy_module_either():
    """`esair std agent` checks its options with click and pydantic, then becomes the lean
    agent process (os.execv): the running agent has neither (it was 48 MB RSS with them)."""
    dep = {"robot": "t",
           "resources": {"count": {"class": "tests.support.lean_comps:Counting", "allow": {"*": "read"}}}}
    ep = free_endpoint()
    rt = Runtime(dep, mode="process", endpoint=ep)
    rt.start()
    proc = subprocess.Popen([sys.executable, "-m", "esair_min.cli", "std", "agent", "--connect",
                             ep, "listen", "tests.support.lean_comps:Listening", "--uses", "count=read"],
                            cwd=HERE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True)
    try:
        received, heavy = wait_for(
            lambda: (lambda r: r if r and r[0] > 0 else None)(
                rt.get("listen", timeout=2.0) if "listen" in rt.bs.records else None),
            timeout=60, what="a sample at the remote behavior")
        pid = {r["name"]: r["pid"] for r in rt.ls()}["listen"]
    finally:
        proc.terminate()
        out, _ = proc.communicate(timeout=30)
        rt.stop()
    assert pid == proc.pid                      # the same process, become the agent
    assert heavy == [], out
    assert proc.returncode == 0, out
