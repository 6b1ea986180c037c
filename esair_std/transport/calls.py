"""Requests and answers carried as samples, matched by an id: the put's path.

Process mode's ``put`` is mediated: the sender asks the runtime's BS, which delivers
into room the target reserved for it and answers at once (modes/process.py), or else
offers the data to the target's process and answers with the target's word. In
zenoh-python a query/reply costs more than a sample each way (side by side in
bench/std_goals.py: a relay through queries 2.3-2.5x a raw get, through samples 1.7x), so the
put takes samples:

    sender  --ctl/put/<sender>-->      BS    (SampleServer in the runtime)
    BS      --bs/<target>/offer-->     target (SampleServer in the target's agent)
    target  --bs/<target>/result-->    BS    (SampleCaller of the runtime)
    BS      --bs/<sender>/answer-->    sender (SampleCaller of the sender's agent)

(the offer and its result only when the target has no reserved room for the put).

Every key names the process it comes from or goes to, so the ACL of a remote agent
(transport/security_config.py) lets it send and receive only its own. Callbacks run on Zenoh's
thread and only copy, enqueue and answer. An answer that does not come within the
timeout (a lost sample, a dead process) is ``None`` to the caller, never a silent loss:
the BS then goes on with its query-based offer and retries; the sender reports the put
failed. Requests may be dropped on a congested link (their caller then times out);
answers never are (a dropped answer to a done request left its caller reporting a
delivered put as failed): one answer per request bounds the wait.
Garbage (not JSON, no id, a foreign id) is counted and dropped.
"""

from __future__ import annotations

import heapq
import itertools
import logging
import queue
import threading
import time
from typing import Callable

from ..errors import TransportError
from .bus import Bus
from .codec import JSON, JSONObject
from ..counters import Counters

log = logging.getLogger("esair_std.transport")
PENDING = 4096           # calls waiting for an answer at once; more are refused at once
PEERS = 1024             # distinct keys a caller sends to / a server answers to


def _id(obj: JSON) -> int | None:
    oid = obj.get("id") if isinstance(obj, dict) else None
    return oid if isinstance(oid, int) and not isinstance(oid, bool) else None


class SampleCaller:
    """Sends requests as samples and matches the answers arriving on ``answers`` (a key
    expression); ``peer_of(answer_key)`` names who answered, which must be whom the
    request went to."""

    def __init__(self, bus: Bus, answers: str, peer_of: Callable[[str], str]):
        self.bus = bus
        self.peer_of = peer_of
        self._ids = itertools.count(1)
        self._pending: dict[int, tuple[str, Callable[[JSON], None], float]] = {}
        self._pubs: dict[str, Callable[[JSON], None]] = {}
        self._lock = threading.Lock()
        self._due = threading.Condition(self._lock)    # an earlier deadline, or closed
        self._deadlines: list[tuple[float, int]] = []  # heap (deadline, id); answered
                                                       # ids are skipped when due
        self._wake_at = float("inf")                   # when the timer wakes next
        self._closed = threading.Event()
        self.c = Counters(calls=0, answers=0, timeouts=0, bad_answers=0)
        bus.subscribe(answers, self._on_answer, with_key=True, garbage=self._garbage)
        self._timer = threading.Thread(target=self._expire, name="esair:calls", daemon=True)
        self._timer.start()

    def _garbage(self, _why: str) -> None:
        self.c.add("bad_answers")

    def call(self, key: str, peer: str, body: JSONObject, timeout: float,
             done: Callable[[JSON], None]) -> bool:
        """Send ``body`` (plus an id) to ``key``; ``done(answer or None)`` once, on a
        Zenoh thread or this caller's timer. False: too many calls wait (not sent).
        TransportError: ``body`` cannot be sent (not JSON, over the size cap)."""
        with self._lock:
            if self._closed.is_set() or len(self._pending) >= PENDING:
                return False
            oid = next(self._ids)
            deadline = time.monotonic() + timeout
            self._pending[oid] = (peer, done, deadline)
            heapq.heappush(self._deadlines, (deadline, oid))
            if deadline < self._wake_at:               # sooner than the timer wakes
                self._wake_at = deadline
                self._due.notify()
            pub = self._pubs.get(key)
            if pub is None:
                if len(self._pubs) >= PEERS:
                    del self._pending[oid]
                    return False
                pub = self._pubs[key] = self.bus.publisher(key, drop=True)
        self.c.add("calls")
        try:
            pub({**body, "id": oid})
        except TransportError:       # not JSON, too big: the caller's error, told at once
            with self._lock:
                self._pending.pop(oid, None)
            raise
        except Exception as exc:  # noqa: BLE001 - not sent: the same as not answered
            log.debug("call on %s not sent: %s", key, exc)
            self._finish(oid, None)
        return True

    def forget(self, key: str) -> None:
        """The peer behind ``key`` is gone: its publisher is given back (bounded tables
        however many peers come and go); a later call declares it again."""
        with self._lock:
            pub = self._pubs.pop(key, None)
        if pub is not None:
            self.bus.undeclare(key)

    def wait(self, key: str, peer: str, body: JSONObject, timeout: float) -> JSON:
        """``call`` from a thread that waits: the answer, or None."""
        box: queue.SimpleQueue[JSON] = queue.SimpleQueue()
        if not self.call(key, peer, body, timeout, box.put):
            return None
        try:
            return box.get(timeout=timeout + 0.01)   # the timer answers None at ``timeout``
        except queue.Empty:
            return None

    def _finish(self, oid: int, answer: JSON) -> bool:
        with self._lock:
            entry = self._pending.pop(oid, None)
        if entry is not None:
            entry[1](answer)
        return entry is not None

    def _on_answer(self, key: str, obj: JSON) -> None:
        oid = _id(obj)
        with self._lock:
            entry = self._pending.get(oid) if oid is not None else None
            if oid is None or entry is None or entry[0] != self.peer_of(key):
                entry = None
            else:
                del self._pending[oid]
        if entry is None:            # garbage, another peer's id, or too late
            self.c.add("bad_answers")
            return
        self.c.add("answers")
        entry[1](obj)

    def _expire(self) -> None:
        """Sleeps until the earliest deadline of a call still waiting (a timer, not a
        tick), woken only by a call due sooner than that: calls answered in time cost it
        about one wake-up per timeout, not one per call."""
        while True:
            with self._due:
                while not self._closed.is_set():
                    while self._deadlines and self._deadlines[0][1] not in self._pending:
                        heapq.heappop(self._deadlines)          # answered already
                    if not self._deadlines:
                        self._wake_at = float("inf")
                        self._due.wait()
                        continue
                    self._wake_at = self._deadlines[0][0]
                    left = self._wake_at - time.monotonic()
                    if left <= 0:
                        break
                    self._due.wait(left)
                if self._closed.is_set():
                    return
                _d, oid = heapq.heappop(self._deadlines)
            if self._finish(oid, None):
                self.c.add("timeouts")

    def close(self) -> None:
        """Every call still waiting is answered None; the timer has ended on return (a
        thread of the runtime must not outlive it: transport/threads.py)."""
        self._closed.set()
        with self._lock:
            self._due.notify_all()
            late = list(self._pending)
        for oid in late:
            self._finish(oid, None)
        if self._timer is not threading.current_thread():
            self._timer.join(2.0)     # it holds no Zenoh call: it ends at once


class SampleServer:
    """Serves requests arriving as samples on ``requests`` (a key expression):
    ``handler(key, body, answer)``, where ``answer(obj)`` sends ``obj`` (plus the id) to
    ``answer_key(request_key)`` once. ``handler`` runs on Zenoh's thread: it must only
    enqueue or answer."""

    def __init__(self, bus: Bus, requests: str, answer_key: Callable[[str], str],
                 handler: Callable[[str, JSONObject, Callable[[JSONObject], None]], None]):
        self.bus = bus
        self.answer_key = answer_key
        self.handler = handler
        self._pubs: dict[str, Callable[[JSON], None]] = {}
        self._lock = threading.Lock()
        self.c = Counters(requests=0, bad_requests=0)
        bus.subscribe(requests, self._on_request, with_key=True, garbage=self._garbage)

    def _garbage(self, _why: str) -> None:
        self.c.add("bad_requests")

    def forget(self, request_key: str) -> None:
        """The peer sending on ``request_key`` is gone: its answer publisher is given
        back; a later request declares it again."""
        with self._lock:
            pub = self._pubs.pop(request_key, None)
        if pub is not None:
            self.bus.undeclare(self.answer_key(request_key))

    def _publisher(self, request_key: str) -> Callable[[JSON], None] | None:
        pub = self._pubs.get(request_key)
        if pub is None:
            with self._lock:
                pub = self._pubs.get(request_key)
                if pub is None:
                    if len(self._pubs) >= PEERS:
                        return None
                    # never dropped: a lost answer leaves its caller waiting for a
                    # request that was done (one answer per request bounds them)
                    pub = self._pubs[request_key] = self.bus.publisher(
                        self.answer_key(request_key), drop=False, express=True)
        return pub

    def _on_request(self, key: str, obj: JSON) -> None:
        oid = _id(obj)
        if oid is None or not isinstance(obj, dict):
            self.c.add("bad_requests")          # garbage: nobody to answer
            return
        pub = self._publisher(key)
        if pub is None:
            self.c.add("bad_requests")          # a flood of made-up senders
            return
        self.c.add("requests")
        sent = [False]

        def answer(out: JSONObject) -> None:
            if not sent[0]:
                sent[0] = True
                try:
                    pub({**out, "id": oid})
                except Exception as exc:  # noqa: BLE001 - the caller times out
                    log.debug("answer on %s not sent: %s", key, exc)
        self.handler(key, obj, answer)
