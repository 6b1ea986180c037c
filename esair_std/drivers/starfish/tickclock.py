"""The central board's tick on the host's clock, from its odometry replies.

An ``O`` reply carries ``n``, the count of the central board's ticks (its Timer2
period; 16 bits) when it read the flow sums; the sums are those of tick ``n``. Tick
``k`` happens at ``W + k * tick`` on the host's clock, ``W`` unknown. Each exchange
bounds ``W``: the board decoded the ``O`` no sooner than its bytes were on the line
after it was written, and after tick ``n`` but before tick ``n + 1``; it answered no
later than the reply's last byte arrived, less the reply's time on the line. So

    written + line(O) - (n + 1) * tick  <  W  <=  replied - line(reply) - n * tick

and the bounds of many exchanges close in on ``W`` when the polls fall at every phase of
the tick (the odometry's polls are dithered over a tick for that, omnilink.Odometry).
:class:`TickClock` keeps the bounds of the last ``window`` exchanges; a robot that
restarted (its count went back) or bounds that no longer meet start it afresh. Pure
computation: times are whatever clock the caller gives (seconds).
"""

from __future__ import annotations

import collections

WINDOW = 200                # exchanges kept: 10 s at 20 Hz (an emulator's pace may drift)


class TickClock:
    def __init__(self, tick_s: float, byte_s: float, window: int = WINDOW):
        self.tick, self.byte = tick_s, byte_s
        self.low: collections.deque[float] = collections.deque(maxlen=window)
        self.high: collections.deque[float] = collections.deque(maxlen=window)
        self.n_prev: int | None = None
        self.wraps = 0
        self.resets = 0

    def count(self, n: int) -> int:
        """``n`` (16 bits) unwrapped; a count that went back by less than half the range
        is a restarted robot: the bounds start afresh."""
        if self.n_prev is not None and n < self.n_prev:
            if self.n_prev - n > 0x8000:
                self.wraps += 1
            else:
                self._reset()
        self.n_prev = n
        return n + 0x10000 * self.wraps

    def _reset(self) -> None:
        self.low.clear()
        self.high.clear()
        self.wraps = 0
        self.resets += 1

    def add(self, n: int, written: float, sent_bytes: int, replied: float,
            reply_bytes: int) -> float:
        """One exchange: the tick count ``n`` of its reply, when its line was written
        (``sent_bytes`` of it) and when the reply (``reply_bytes``, its end included)
        had arrived. Returns the host's time of tick ``n``."""
        k = self.count(n)
        low = written + (sent_bytes - 1) * self.byte - (k + 1) * self.tick
        high = replied - reply_bytes * self.byte - k * self.tick
        if self.low and (low > min(self.high) or high < max(self.low)):
            self._reset()                   # bounds that do not meet: a new pace
        self.low.append(low)
        self.high.append(high)
        return self.origin() + k * self.tick

    def origin(self) -> float:
        """``W``: the middle of what the bounds leave."""
        return (max(self.low) + min(self.high)) / 2

    def spread(self) -> float:
        """How far ``W`` may be from :meth:`origin` (half the bounds' gap)."""
        return (min(self.high) - max(self.low)) / 2
