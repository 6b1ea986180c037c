"""Messages handed from any thread (Zenoh's, the bridge's poller) to a server's asyncio
loop (the HMI's server, the live Foxglove server): a bounded list, and the loop woken
once for all that come meanwhile. An urgent message (a sample) wakes the loop now; a
lazy one (a command's record, the link bar...) does not: it goes with the next urgent
one's flush, or with a tick every ``lazy_s`` while lazy ones come, so a stream of them
costs no wake-up of its own while samples flow."""

from __future__ import annotations

import asyncio
import threading
from typing import Callable

from ..transport.codec import JSONObject


class Handover:
    def __init__(self, flush: Callable[[], None], lazy_s: float, limit: int):
        self.flush, self.lazy_s, self.limit = flush, lazy_s, limit
        self.loop: asyncio.AbstractEventLoop | None = None     # set by the loop's owner
        self._items: list[JSONObject] = []
        self._lock = threading.Lock()
        self._soon = False        # a flush is asked for, as soon as the loop can
        self._armed = False       # the lazy tick is due within lazy_s
        self._seen = False        # a lazy message came since the last tick

    def put(self, msg: JSONObject, lazy: bool) -> bool:
        """Any thread: queue ``msg``; False when the list is full (the caller counts
        the drop). Before the loop runs, nothing is queued."""
        loop = self.loop
        if loop is None or loop.is_closed():
            return True
        with self._lock:
            if len(self._items) >= self.limit:
                return False
            self._items.append(msg)
            if lazy:
                self._seen = True
                if self._soon or self._armed:
                    return True
                self._armed = True
                call = self._arm
            else:
                if self._soon:
                    return True
                self._soon = True
                call = self.flush
        loop.call_soon_threadsafe(call)
        return True

    def take(self) -> list[JSONObject]:
        """The loop (in ``flush``): everything queued, in order."""
        with self._lock:
            got, self._items = self._items, []
            self._soon = False
        return got

    def _arm(self) -> None:
        assert self.loop is not None
        self.loop.call_later(self.lazy_s, self._tick)

    def _tick(self) -> None:
        """What waits goes now (when no urgent flush took it); after a tick with no lazy
        message since the last, the tick stops."""
        with self._lock:
            again, self._seen = self._seen, False
            self._armed = again
            waiting = bool(self._items)
        if waiting:
            self.flush()
        if again:
            self._arm()
