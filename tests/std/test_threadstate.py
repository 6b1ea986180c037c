"""Zenoh's threads keep their Python thread state between the bus's callbacks
(esair_std/transport/threadstate.py): what a thread-local holds on a Zenoh thread lasts
from one callback to the next on that thread, as on any Python thread. Without it each
callback ran in a thread state made for it alone (and the thread-local was new each time)."""

from __future__ import annotations

import json
import os
import queue
import subprocess
import sys
import threading
import time

from tests.support.std import ROOT, free_endpoint

from esair_std.transport.bus import Bus

SAMPLES = 40      # more than the threads of any Zenoh pool here: some thread runs two


def test_a_zenoh_thread_keeps_its_python_state_between_callbacks():
    """In a process of its own: a test worker has run many sessions' threads before."""
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run([sys.executable, "-c", "from tests.std.test_threadstate import "
                           "callbacks_by_thread as f; import json; print(json.dumps(f()))"],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    calls: dict[str, list[int]] = json.loads(proc.stdout)
    assert max(len(ns) for ns in calls.values()) >= 2
    # each thread counted every callback it ran: 1, 2, 3... (not 1, 1, 1...)
    assert all(ns == list(range(1, len(ns) + 1)) for ns in calls.values()), calls


def callbacks_by_thread() -> dict[str, list[int]]:
    """Each Zenoh thread's count of the callbacks it ran, as its thread-local kept it."""
    ep = free_endpoint()
    receiver, sender = Bus(listen=[ep]), Bus(connect=[ep])
    local = threading.local()
    seen: queue.SimpleQueue[tuple[int, int, object]] = queue.SimpleQueue()

    def on_sample(obj: object) -> None:
        local.calls = getattr(local, "calls", 0) + 1
        seen.put((threading.get_ident(), local.calls, obj))
    try:
        receiver.subscribe("esair/threadstate/x", on_sample)
        put = sender.publisher("esair/threadstate/x")
        got = []
        deadline = time.monotonic() + 20
        while not got:                   # until the subscription has reached the sender
            assert time.monotonic() < deadline, "no sample arrived"
            put("warm-up")
            try:
                got.append(seen.get(timeout=0.1))
            except queue.Empty:
                pass
        for i in range(SAMPLES):
            put(i)
        while not got or got[-1][2] != SAMPLES - 1:
            got.append(seen.get(timeout=10))
    finally:
        sender.close()
        receiver.close()
    calls: dict[str, list[int]] = {}
    for ident, n, _obj in got:
        calls.setdefault(str(ident), []).append(n)
    return calls
