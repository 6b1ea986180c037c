"""The control endpoint stays responsive (issue 37 item 5): ``ls`` and ``ping`` are
answered while every worker of the control endpoint waits on a put that cannot end yet
(a target busy by its own word: the BS retries until the put's timeout). Shown by the
order of events: the test frees the target only once ``ls`` and ``ping`` were answered,
so an endpoint that queues them behind the waiting puts answers the puts first (at
their timeout), and only then the listing."""

from __future__ import annotations

import threading

from esair_std.cli.client import Client
from esair_std.control.control_server import WORKERS
from tests.support.std import wait_for

PUTS = WORKERS + 2        # more than the pool: every worker waits, two more queue
PUT_TIMEOUT = 8.0         # the puts give up then, if the target was never freed


def test_ls_and_ping_answer_while_every_worker_waits_on_a_put(start, tmp_path):
    release = tmp_path / "release"
    rt = start({"behaviors": {"gate": {"class": "tests.support.comps:Gate",
                                       "release": str(release)}}}, control=True)
    rt.put("gate", "close")
    wait_for(lambda: rt.state("gate") == "busy", 10, what="the gate to close")
    refused0 = rt.inspect("gate")["counters"]["refused"]
    events: list[str] = []
    lock = threading.Lock()
    with Client(rt.endpoint, robot="t") as c:
        def put(i: int) -> None:
            r = c.call("put", {"to": "gate", "data": i, "timeout": PUT_TIMEOUT},
                       PUT_TIMEOUT + 10)
            with lock:
                events.append(f"put {r['delivered']}")

        puts = [threading.Thread(target=put, args=(i,), daemon=True) for i in range(PUTS)]
        for t in puts:
            t.start()
        # each put's retries reach the gate (refused, counted): the workers are in them
        wait_for(lambda: rt.inspect("gate")["counters"]["refused"] >= refused0 + 3 * PUTS,
                 PUT_TIMEOUT / 2, what="the puts to retry at the busy gate")
        rows = c.call("ls", None, PUT_TIMEOUT + 10)
        with lock:
            events.append("ls")
        pong = c.call("ping", None, PUT_TIMEOUT + 10)
        with lock:
            events.append("ping")
        release.touch()                  # only now: the puts end, delivered
        for t in puts:
            t.join(PUT_TIMEOUT + 15)
    assert {r["name"]: r["state"] for r in rows} == {"gate": "busy"}
    assert pong["robot"] == "t"
    assert events[:2] == ["ls", "ping"], f"ls/ping waited behind the puts: {events}"
    assert events[2:] == ["put True"] * PUTS, events
