"""`esair std agent` says on standard error that it joined (robot, endpoint, host, what
it hosts: uses or allows, how it is stopped) and, when it leaves, why. Agents exist in
process mode only (a thread-mode runtime takes no remote agents)."""

import select
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from tests.support.std import free_endpoint, wait_for
from esair_std import Runtime

HERE = Path(__file__).resolve().parents[2]
DEP = {"robot": "t", "resources": {"count": {"class": "tests.support.lean_comps:Counting",
                                             "allow": {"*": "read"}}}}


@pytest.fixture(scope="module")
def center():
    ep = free_endpoint()
    rt = Runtime(DEP, mode="process", endpoint=ep)
    rt.start()
    try:
        yield rt, ep
    finally:
        rt.stop()


def agent(ep: str, *args: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "esair_min.cli", "std", "agent", "--connect",
                             ep, "--host-name", "lab-pc", *args], cwd=HERE,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def first_line(proc: subprocess.Popen, timeout: float = 60.0) -> str:
    """Its first line on standard error (waited for, at most ``timeout``)."""
    ready, _, _ = select.select([proc.stderr], [], [], timeout)
    assert ready, "the agent said nothing"
    return proc.stderr.readline()


def said(ep: str, args: tuple[str, ...], joined: str, then) -> tuple[int, str, str]:
    """Start an agent; its first line must be ``joined``; ``then(proc)`` makes it leave;
    its status, standard output and the rest of its standard error."""
    proc = agent(ep, *args)
    try:
        assert first_line(proc) == joined
        then(proc)
        out, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    return proc.returncode, out, err


def test_a_behavior_agent_says_it_joined_and_that_it_was_removed(center):
    rt, ep = center

    def remove(proc):
        wait_for(lambda: rt.state("listen") == "running", timeout=30, what="listen running")
        rt.remove("listen")
    assert said(ep, ("listen", "tests.support.lean_comps:Listening", "--uses", "count=read"),
                f"agent 'listen' joined robot 't' at {ep} as host 'lab-pc': behavior "
                "tests.support.lean_comps:Listening, uses count=read; runs until Ctrl-C or "
                "`esair std remove listen`\n", remove) == (
        0, "", "agent 'listen' left robot 't': stopped by the control center\n")


def test_a_driver_agent_lists_its_resources_and_says_it_was_interrupted(center):
    _, ep = center
    assert said(ep, ("bench", "esair_std.drivers.sim:Bench", "--allow", "*=read"),
                f"agent 'bench' joined robot 't' at {ep} as host 'lab-pc': driver "
                "esair_std.drivers.sim:Bench (bench.temp: sensor, bench.fan: actuator), allows "
                "*=read; runs until Ctrl-C or `esair std remove-resource bench`\n",
                lambda proc: proc.send_signal(signal.SIGINT)) == (
        0, "", "agent 'bench' left robot 't': interrupted\n")


def test_a_resource_agent_says_what_it_is_and_who_may_use_it(center):
    rt, ep = center
    assert said(ep, ("pen", "esair_std.drivers.sim:Recorder", "--allow", "operator=command",
                     "--allow", "follow=configure"),
                f"agent 'pen' joined robot 't' at {ep} as host 'lab-pc': actuator "
                "esair_std.drivers.sim:Recorder, allows operator=command, follow=configure; runs "
                "until Ctrl-C or `esair std remove-resource pen`\n",
                lambda proc: rt.remove_resource("pen")) == (
        0, "", "agent 'pen' left robot 't': stopped by the control center\n")
