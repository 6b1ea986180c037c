"""A process that STD owns freezes its start-up heap (esair_std/heap.py: a full garbage
collection then walks only what was made since, so no command waits behind one of
30-270 ms): an agent process once its component or resource has started, and
`esair std run`'s process once the runtime has; in both modes. A runtime used as a
library leaves its caller's collector alone."""

import gc
import json
import weakref

import pytest

from esair_std import Runtime
from esair_std.heap import settle
from tests.support.std import MODES, esair, free_endpoint, std_run, wait_for

DEP = {"robot": "t",
       "resources": {"count": {"class": "tests.support.lean_comps:Counting",
                               "allow": {"*": "read"}}},
       "behaviors": {"probe": {"class": "tests.support.lean_comps:Frozen"}}}


@pytest.mark.parametrize("mode", MODES)
def test_esair_std_run_freezes_its_start_up_heap(mode, tmp_path):
    dep = tmp_path / "dep.json"          # JSON is YAML: the deployment loader reads it
    dep.write_text(json.dumps(DEP))
    ep = free_endpoint()

    def probed():
        r = esair("get", "probe", "-e", ep, check=False)
        return json.loads(r.stdout) if r.returncode == 0 else None
    with std_run(str(dep), mode, ep, probed, "the probe answering"):
        got = wait_for(lambda: (lambda r: r if r and r["frozen"] > 0 else None)(probed()),
                       timeout=30, what="the probe's process frozen")
        frozen = json.loads(esair("configure", "count", "frozen", "1", "-e", ep).stdout)
    assert got["frozen"] > 1000           # the runtime's (thread) or the agent's (process)
    assert frozen > 1000                  # the resource's host: the same process in
                                          # thread mode, its agent in process mode


def test_a_library_runtime_leaves_the_callers_collector_alone():
    before = gc.get_freeze_count()
    rt = Runtime(DEP, mode="thread", endpoint=free_endpoint())
    rt.start()
    try:
        wait_for(lambda: rt.get("probe", timeout=2.0), what="the probe")
        assert rt.get("probe", timeout=2.0) == {"frozen": before}
    finally:
        rt.stop()


def test_settle_collects_the_young_garbage_then_freezes():
    class Cycle:
        pass
    gc.disable()            # no automatic collection moves the cycle to the old generation
    try:
        a = Cycle()
        a.me = a                          # garbage only the collector frees
        gone = weakref.ref(a)
        del a
        n = settle()
        assert n > 1000 and gc.get_freeze_count() > 1000     # (objects freed since leave it)
        assert gone() is None             # collected first, not frozen
    finally:
        gc.unfreeze()
        gc.enable()
