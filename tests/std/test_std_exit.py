"""A runtime used as a library leaves nothing behind that can abort the program at its
exit (issue 19: "FATAL: exception not rethrown", SIGABRT).

A Python thread that is inside a Zenoh call while the interpreter finalizes is ended
with pthread_exit when the call returns; glibc then aborts the process
(esair_std/transport/threads.py). So ``Runtime.stop()`` returns only once every thread of
the runtime that may call into Zenoh has ended, and a program that never calls it is not
left hanging by Zenoh's threads or aborted: the runtime is stopped at its exit."""

from __future__ import annotations

import subprocess
import sys
import threading
from pathlib import Path

import pytest

from esair_std import Runtime
from esair_std.transport.threads import Threads
from tests.support.std import MODES, free_endpoint

HERE = Path(__file__).resolve().parents[2]

DEPLOYMENT = {
    "robot": "t",
    "resources": {"count": {"class": "tests.support.comps:Counter", "options": {"rate": 500},
                            "allow": {"*": "read"}},
                  "rec": {"class": "tests.support.comps:Recorder", "allow": {"*": "command"}}},
    "behaviors": {"sink": {"class": "tests.support.comps:Sink"},
                  "watch": {"class": "tests.support.comps:Watcher", "period": 0.02,
                            "uses": {"count": "read"}},
                  "cmd": {"class": "tests.support.comps:Commander", "uses": {"rec": "command"}}},
}


@pytest.mark.parametrize("mode", MODES)
def test_stop_returns_once_the_runtimes_threads_have_ended(mode):
    """Before: in process mode the control workers and the put path's timer (daemon
    threads) were still alive when stop() returned; under load one of them could be
    inside a Zenoh call when the program finalized."""
    before = set(threading.enumerate())
    rt = Runtime(DEPLOYMENT, mode=mode, endpoint=free_endpoint(), control=True)
    rt.start()
    try:
        for i in range(5):
            rt.put("sink", i)
            rt.put("cmd", {"n": i})
    finally:
        rt.stop()
    left = [t.name for t in threading.enumerate()
            if t not in before and t.daemon and t.is_alive()]
    assert left == []


SCRIPT = """
import sys
from esair_std import Runtime
rt = Runtime({"robot": "t", "behaviors": {"sink": {"class": "tests.support.comps:Sink"}}},
             mode=sys.argv[1], endpoint=sys.argv[2], control=True)
rt.start()
rt.put("sink", "x")
print("leaving without stop()", flush=True)
"""


@pytest.mark.parametrize("mode", MODES)
def test_a_program_that_never_stops_its_runtime_still_exits(mode):
    """Before: in process mode the program hung at its exit for ever (zenoh-python's
    liveliness thread, not a daemon, lives as long as the session that nobody closed)."""
    try:
        out = subprocess.run([sys.executable, "-c", SCRIPT, mode, free_endpoint()], cwd=HERE,
                             capture_output=True, text=True, timeout=60)
    except subprocess.TimeoutExpired:
        pytest.fail("the program did not exit within 60 s")
    assert (out.returncode, out.stdout) == (0, "leaving without stop()\n"), out.stderr


def test_threads_join_waits_for_all_and_names_those_still_running():
    threads = Threads()
    release = threading.Event()
    done = threading.Event()
    threads.start(done.set, name="quick")
    threads.start(release.wait, name="held")
    done.wait(10.0)
    assert threads.join(0.05) == ["held"]
    release.set()
    assert threads.join(10.0) == []
    me = threads.start(lambda: threads.join(10.0), name="self")   # never waits for itself
    me.join(10.0)
    assert not me.is_alive()
