"""Process mode's fork server (issue 37 item 2): agents are forked from a zygote that
imported the agent's code once, and share those pages; each is still the runtime's own
child (waited for, killed by pid, its exit status read), writes to the runtime's
stderr as it is at the agent's start, and starts in the runtime's folder. Without the
zygote (it died, or ESAIR_STD_FORK=0) agents start as new interpreters, as before."""

import os
import signal

import pytest

from esair_std import Runtime
from esair_std.deploy import load_deployment
from tests.support.std import agent_children, free_endpoint, processes, wait_for

pytestmark = pytest.mark.slow

SAYS = """\
import os
import sys

from esair_std import Behavior


class Says(Behavior):
    period = 0.1

    def start(self):
        sys.stderr.write(f"says from {os.getpid()} in {os.getcwd()}\\n")
        sys.stderr.flush()

    def provide(self, requester):
        return {"pid": os.getpid(), "argv0": sys.argv[0]}
"""


@pytest.fixture
def folder(tmp_path, monkeypatch):
    (tmp_path / "says.py").write_text(SAYS)
    monkeypatch.chdir(tmp_path)
    return tmp_path


def _shared_dirty_kb(pid: int) -> int:
    """Anonymous pages it shares with another process written before: a forked child
    shares its parent's heap, a new interpreter shares none."""
    with open(f"/proc/{pid}/smaps_rollup") as f:
        for line in f:
            if line.startswith("Shared_Dirty:"):
                return int(line.split()[1])
    return 0


def _zygotes() -> list[int]:
    return [pid for pid, ppid, cmd in processes()
            if ppid == os.getpid() and b"esair_std.hosts.zygote" in cmd]


def _runtime(folder, *names):
    dep = {"robot": "t", "mode": "process",
           "behaviors": {n: {"class": "says:Says", "restart": {"max": 3, "within": 600}}
                         for n in names}}
    return Runtime(load_deployment(dep, base_dir=str(folder)), endpoint=free_endpoint())


def test_agents_are_forked_children_of_the_runtime_sharing_the_zygote(folder, capfd):
    rt = _runtime(folder, "a", "b")
    rt.start()
    try:
        pids = {r["name"]: r["pid"] for r in rt.ls()}
        assert sorted(agent_children()) == sorted(pids.values())   # the runtime's own
        assert len(_zygotes()) == 1
        for name, pid in pids.items():
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                cmd = f.read().split(b"\0")
            assert b"esair_std.hosts.agent_process" in cmd and b"--spec" in cmd
            assert f'"name": "{name}"'.encode() in cmd[cmd.index(b"--spec") + 1]
            assert _shared_dirty_kb(pid) > 1024, "not forked from the zygote"
            got = rt.get(name, timeout=5.0)
            assert got["pid"] == pid and got["argv0"].endswith("agent_process.py")
        os.kill(pids["a"], signal.SIGKILL)                  # a crash: restarted, forked
        def restarted():
            a = {r["name"]: r for r in rt.ls()}.get("a")
            return a is not None and a["pid"] != pids["a"] and a["state"] == "running"
        wait_for(restarted, 60, "a restarted")
        again = {r["name"]: r["pid"] for r in rt.ls()}["a"]
        assert _shared_dirty_kb(again) > 1024
    finally:
        rt.stop()
    assert agent_children() == [] and _zygotes() == [], "processes left behind"
    err = capfd.readouterr().err
    for pid in (*pids.values(), again):
        assert f"says from {pid} in {folder}" in err


def test_without_the_zygote_agents_start_as_new_interpreters(folder, capfd):
    rt = _runtime(folder, "a")
    rt.start()
    try:
        [zygote] = _zygotes()
        os.kill(zygote, signal.SIGKILL)
        wait_for(lambda: zygote not in _zygotes(), 30, "the zygote gone")
        rt.add("b", "says:Says")
        pid = {r["name"]: r["pid"] for r in rt.ls()}["b"]
        assert pid in agent_children()
        assert _shared_dirty_kb(pid) < 1024, "forked, yet the zygote was killed"
        assert rt.get("b", timeout=5.0)["pid"] == pid
    finally:
        rt.stop()
    assert agent_children() == [], "agent processes left behind"
    assert f"says from {pid} in {folder}" in capfd.readouterr().err


def test_the_fork_server_can_be_turned_off(folder, monkeypatch):
    monkeypatch.setenv("ESAIR_STD_FORK", "0")
    rt = _runtime(folder, "a")
    rt.start()
    try:
        assert _zygotes() == []
        pid = {r["name"]: r["pid"] for r in rt.ls()}["a"]
        assert _shared_dirty_kb(pid) < 1024
    finally:
        rt.stop()
