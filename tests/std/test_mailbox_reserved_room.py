"""The mailbox's two kinds of room (hosts/behavior_host.py), driven on a real
ComponentHost with its own thread: plain offers (at most INBOX waiting) never take the
room reserved for the BS's deliveries (RESERVED), whatever the behavior's thread does
meanwhile. A delivery into reserved room was told "delivered" before it came, so a
refused one is a delivered put lost (issue 37 item 3; seen in process mode as
test_bursts_from_two_senders_arrive_once_each_in_order losing one put in three runs)."""

from __future__ import annotations

import queue
import threading

from esair_std.behavior import Behavior
from esair_std.hosts.behavior_host import INBOX, RESERVED, ComponentHost
from esair_std.spec import Spec
from tests.support.std import wait_for


class _Port:
    """The runtime side of the host: only its phase reports are called here."""

    def state_changed(self, name: str, generation: int, phase: str, reason: str) -> None:
        pass


class _Held(Behavior):
    """receive() takes one permit per put: the test decides when each one is taken."""

    permits = threading.Semaphore(0)
    got: list[object] = []

    def receive(self, sender, data):
        while not self.permits.acquire(timeout=0.05):
            if self.stopping:
                return
        self.got.append(data)


class _PausingInbox(queue.Queue):
    """The mailbox, pausing its reader just after it took a reserved delivery out (as a
    thread switch may), until another thread has made its offer or a moment passed."""

    def __init__(self, maxsize: int):
        super().__init__(maxsize)
        self.armed = False
        self.paused = threading.Event()
        self.go = threading.Event()

    def get_nowait(self):
        item = super().get_nowait()
        if self.armed and item[0] == "reserved":
            self.armed = False
            self.paused.set()
            self.go.wait(1.0)       # the fixed code holds the offer off: no deadlock
        return item


def test_an_offer_made_while_a_reserved_delivery_is_taken_out_leaves_the_reserved_room():
    _Held.got = []
    _Held.permits = threading.Semaphore(0)
    spec = Spec("behavior", "held", "tests:_Held", options={"deadline": 120})
    host = ComponentHost(spec, _Held, _Port())  # type: ignore[arg-type]
    inbox = host.inbox = _PausingInbox(INBOX + RESERVED)
    host.start()
    try:
        assert host.started.wait(10) and host.state == "running"
        assert host.offer("op", "first") == "delivered"
        wait_for(lambda: inbox.empty(), 10, what="receive() to hold the first put")
        assert host.deliver_reserved("bs", "r0")
        while host.offer("op", "plain") == "delivered":
            pass
        told = 1 + 1 + INBOX
        assert host.c["received"] == 0 and inbox.qsize() == 1 + INBOX
        inbox.armed = True
        _Held.permits.release()                  # "first" done; r0 is taken out next
        assert inbox.paused.wait(10)
        extra: list[str] = []
        offer = threading.Thread(target=lambda: (extra.append(host.offer("op", "extra")),
                                                 inbox.go.set()))
        offer.start()
        offer.join(10)
        assert extra == ["busy"], "a plain offer took the slot r0 left"
        # r0 is out (receive() waits on it): the whole reserved room is the BS's again
        assert [host.deliver_reserved("bs", f"r{i}") for i in range(1, RESERVED + 1)] \
            == [True] * RESERVED
        told += RESERVED
        assert host.c["reserved_refused"] == 0
        for _ in range(told):
            _Held.permits.release()
        wait_for(lambda: len(_Held.got) >= told, 30, what="every delivered put")
        assert len(_Held.got) == told
        assert _Held.got.count("extra") == 0
        assert [d for d in _Held.got if str(d).startswith("r")] == \
            [f"r{i}" for i in range(RESERVED + 1)]
    finally:
        host.stop()
