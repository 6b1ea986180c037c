"""A deterministic virtual clock: a scheduler of timed events, no sleeping.

Time is an integer number of nanoseconds since reset, so that every run of the same
input gives the same order of events. Events due at the same instant run in the order
they were scheduled.
"""

from __future__ import annotations

import heapq
from typing import Callable

NS_PER_S = 1_000_000_000

Callback = Callable[[], None]
_heappush = heapq.heappush


def seconds_to_ns(seconds: float) -> int:
    return int(round(seconds * NS_PER_S))


class VirtualClock:
    """``schedule`` callbacks at virtual times; ``run_until`` runs them in time order."""

    def __init__(self) -> None:
        #: Virtual time in nanoseconds (read it; only the clock moves it).
        self.now = 0
        self._queue: list[tuple[int, int, Callback]] = []
        self._seq = 0
        self._limit = -1          # how far the current run_until may go

    @property
    def now_s(self) -> float:
        return self.now / NS_PER_S

    def schedule(self, at_ns: int, callback: Callback) -> None:
        """Run ``callback`` at ``at_ns`` (never earlier than now)."""
        if at_ns < self.now:
            at_ns = self.now
        seq = self._seq = self._seq + 1
        _heappush(self._queue, (at_ns, seq, callback))

    def after(self, delay_ns: int, callback: Callback) -> None:
        self.schedule(self.now + delay_ns, callback)

    def next_event(self) -> int | None:
        """Time of the next pending event, or None when nothing is scheduled."""
        return self._queue[0][0] if self._queue else None

    def advance_inline(self, t_ns: int) -> bool:
        """Let the running event move time on to ``t_ns`` itself, if nothing else is due
        before (or at) then and the run goes that far; True if time moved.

        A fast path for streams of events (bytes on a line): the same order and times
        as scheduling each one, without the heap."""
        q = self._queue
        if t_ns <= self._limit and (not q or t_ns < q[0][0]):
            if t_ns > self.now:
                self.now = t_ns
            return True
        return False

    def inline_limit(self) -> int:
        """The latest time the running event may move time on to itself (see
        :meth:`advance_inline`): before the next pending event and within the run;
        below ``now`` when nothing else may happen before the next event."""
        q = self._queue
        if q and q[0][0] <= self._limit:
            return q[0][0] - 1
        return self._limit

    def stop_at(self, t_ns: int) -> None:
        """Let the running :meth:`run_until` end at ``t_ns`` if that is sooner (an event
        found that the caller must look at then); nothing when no run is under way."""
        if self.now <= t_ns < self._limit:
            self._limit = t_ns

    def run_until(self, t_ns: int) -> int:
        """Run every event due at or before ``t_ns`` (or an earlier :meth:`stop_at`),
        then set the time to it.

        Returns the number of events run.
        """
        q = self._queue
        pop = heapq.heappop
        n = 0
        self._limit = t_ns
        try:
            while q and q[0][0] <= self._limit:
                at, _, cb = pop(q)
                if at > self.now:
                    self.now = at
                cb()
                n += 1
            t_ns = self._limit
        finally:
            self._limit = -1
        if t_ns > self.now:
            self.now = t_ns
        return n

    def run_for(self, seconds: float) -> int:
        return self.run_until(self.now + seconds_to_ns(seconds))
