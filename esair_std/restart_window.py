"""The restart intensity of every supervised thing in ESAIR STD (OTP's ``MaxR`` in
``MaxT``): at most ``max`` restarts in any ``within`` seconds.

One rule for the supervisor (behaviors, reactions, resource entries), a remote agent's
behavior and a MIN link's emulated robot. A restart exactly ``within`` seconds ago still
counts, as in OTP's ``supervisor.erl`` (a restart at ``Then`` counts while
``Now - Then =< Period``).
"""

from __future__ import annotations

from collections import deque


class RestartWindow:
    """The restarts of one child in the last ``within`` seconds, against ``max``."""

    def __init__(self, max: int, within: float) -> None:
        self.max = max
        self.within = within
        self._times: deque[float] = deque()

    def allow(self, now: float) -> bool:
        """Whether a restart at ``now`` (``time.monotonic()``) stays within the limit;
        if it does, it is counted."""
        times = self._times
        while times and now - times[0] > self.within:
            times.popleft()
        if len(times) >= self.max:
            return False
        times.append(now)
        return True

    def __len__(self) -> int:
        """The restarts counted in the window as of the last :meth:`allow`."""
        return len(self._times)
