"""A hello cut short by a process that died (issue 34 item 5), process mode: an agent
killed while it starts fails its start at once, saying how it ended; an agent whose
runtime is killed while it says hello leaves at once and quietly (it waited out its 10 s
hello, then logged "runtime refused hello: None" and exited 1)."""

import os
import signal
import subprocess
import sys
import threading

import pytest

from esair_std import Runtime
from esair_std.deploy import load_deployment
from esair_std.errors import ComponentError
from tests.support.std import ROOT, free_endpoint, processes, wait_for

#: a behavior module whose import, in the component's own process only, waits for a
#: line on the fifo beside it: the test holds the agent there
HELD = """\
import os
import sys

if "agent_process" in sys.argv[0]:
    with open(os.path.join(os.path.dirname(os.path.abspath(__file__)), "fifo")) as f:
        f.read()

from esair_std import Behavior


class Held(Behavior):
    period = 0.1
"""


@pytest.fixture
def folder(tmp_path):
    (tmp_path / "held.py").write_text(HELD)
    os.mkfifo(tmp_path / "fifo")
    return tmp_path


def _agent_of(parent: int):
    found = [pid for pid, ppid, cmd in processes()
             if ppid == parent and b"agent_process" in cmd and b"held" in cmd]
    return found[0] if found else None


def test_an_agent_killed_while_it_starts_fails_the_start_at_once(folder):
    rt = Runtime(load_deployment({"robot": "t", "mode": "process"}, base_dir=str(folder)),
                 endpoint=free_endpoint())
    rt.start()
    try:
        def kill():
            pid = wait_for(lambda: _agent_of(os.getpid()), 60, "the agent process")
            os.kill(pid, signal.SIGKILL)
        killer = threading.Thread(target=kill)
        killer.start()
        with pytest.raises(ComponentError) as exc:
            rt.add("held", "held:Held")
        killer.join(10)
        assert str(exc.value) == ("behavior 'held': its process was killed by signal 9 before "
                                  "it started")
        assert [r["name"] for r in rt.ls()] == []
    finally:
        rt.stop()


def test_an_agent_whose_runtime_is_killed_during_its_hello_leaves_at_once(folder):
    (folder / "robot.yaml").write_text("robot: t\nmode: process\nbehaviors:\n"
                                       "  held: {class: 'held:Held'}\n")
    run = subprocess.Popen([sys.executable, "-m", "esair_min.cli", "std", "run",
                            str(folder / "robot.yaml"), "-e", free_endpoint(), "--no-top"],
                           cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                           text=True)
    try:
        wait_for(lambda: run.poll() is not None or _agent_of(run.pid), 60,
                         "the agent process")
        assert run.poll() is None, run.communicate()
        # the runtime stops answering; the agent goes on to its hello, then the runtime dies
        os.kill(run.pid, signal.SIGSTOP)
        with open(folder / "fifo", "w") as f:
            f.write("go\n")
        os.kill(run.pid, signal.SIGKILL)
        run.wait(30)
        # the agent holds the runtime's stderr: its end is the agent's exit
        said = run.stderr.read()
    finally:
        if run.poll() is None:
            run.kill()
            run.wait(10)
    assert "refused hello" not in said and "Traceback" not in said, said
