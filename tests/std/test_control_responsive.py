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
from esair_std.errors import ControlError
from esair_std.hosts.behavior_host import INBOX
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


BIG = "x" * 9000        # over modes/process.py's RESERVED_BYTES: a plain offer, never reserved


def test_a_full_mailbox_is_listed_busy_and_running_again_once_it_drains(start, tmp_path):
    """In process mode ``ls`` now takes a behavior's state from its own reports, not by
    asking its process: a mailbox filled by plain offers while receive() is held must
    still be listed busy, and running again once the behavior drains it."""
    release = tmp_path / "release"
    rt = start({"behaviors": {"sink": {"class": "tests.support.comps:GatedSink",
                                       "release": str(release), "deadline": 120}}},
               control=True)

    def listed() -> str:
        return {r["name"]: r["state"] for r in rt.ls()}["sink"]

    assert listed() == "running"
    sent = 0
    while True:                          # plain offers until the mailbox takes no more
        try:
            rt.put("sink", {"i": sent, "pad": BIG}, timeout=0.3)
        except ControlError:
            break
        sent += 1
        assert sent <= 10 * INBOX, "the mailbox never filled"
    wait_for(lambda: listed() == "busy", 10, what="the full mailbox listed busy")
    assert rt.state("sink") == "busy"
    release.touch()
    wait_for(lambda: len(rt.get("sink", timeout=5.0)["got"]) == sent, 60,
             what="the mailbox to drain")
    wait_for(lambda: listed() == "running", 10, what="the drained mailbox listed running")
