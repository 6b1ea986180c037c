"""Every put is answered (issue 37 item 3): a component process's put travels as a
sample and its answer comes back as one (transport/calls.py). A burst of requests, each
answered at once on the Zenoh thread that took it, must get every answer: an answer
sent so that a busy link may drop it leaves its sender waiting for a put that was
delivered (the cause of tests/std/test_std_cli.py's one unanswered put in four)."""

from __future__ import annotations

import threading
import time

import zenoh

from esair_std.transport.bus import Bus
from esair_std.transport.calls import SampleServer
from tests.support.std import free_endpoint

N = 3000


def test_a_burst_of_requests_gets_every_answer():
    ep = free_endpoint()
    server_bus = Bus(listen=[ep])
    client = Bus(connect=[ep])
    got: set[int] = set()
    cond = threading.Condition()

    def on_answer(obj):
        with cond:
            got.add(obj["id"])
            cond.notify_all()
    try:
        server = SampleServer(server_bus, "t/ctl/put/*",
                              lambda k: "t/answer/" + k.rsplit("/", 1)[1],
                              lambda key, body, answer: answer({"ok": body["n"]}))
        client.subscribe("t/answer/me", on_answer)
        # the subscription and the server's must be known to both sides: ask until one
        # answer comes
        while not got:
            client.session.put("t/ctl/put/me", b'{"id": 0, "n": 0}')
            with cond:
                cond.wait(0.2)
        for i in range(1, N + 1):
            client.session.put("t/ctl/put/me", f'{{"id": {i}, "n": {i}}}'.encode(),
                               congestion_control=zenoh.CongestionControl.BLOCK)
        # wait while answers still come (no progress for 10 s: the rest are lost)
        seen, still = -1, time.monotonic()
        while len(got) < N + 1 and time.monotonic() - still < 10:
            with cond:
                cond.wait(0.5)
                if len(got) != seen:
                    seen, still = len(got), time.monotonic()
        assert server.c.snapshot()["requests"] >= N
        assert len(got - {0}) == N, f"{N - len(got - {0})} of {N} answers lost"
    finally:
        client.close()
        server_bus.close()
