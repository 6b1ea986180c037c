"""Real-time pacing: virtual time follows the wall clock (for a person at a terminal).

The emulator itself never sleeps; a :class:`Pacer` advances it to
``(wall time since start) * factor`` whenever asked, and tells a server loop how long
it may sleep before the robot next does something.
"""

from __future__ import annotations

import time

from esair_min.emulator.clock import NS_PER_S
from esair_min.emulator.line import SerialHost


class Pacer:
    """Keeps ``emu``'s virtual time at ``factor`` times the wall clock since creation."""

    def __init__(self, emu: SerialHost, factor: float = 1.0,
                 wall=time.monotonic):
        self.emu = emu
        self.factor = factor
        self._wall = wall
        self._t0_wall = wall()
        self._t0_virtual = emu.clock.now

    def target_ns(self) -> int:
        return self._t0_virtual + int((self._wall() - self._t0_wall) * self.factor * NS_PER_S)

    def sync(self) -> None:
        """Run the emulator up to now (wall clock)."""
        t = self.target_ns()
        if t > self.emu.clock.now:
            self.emu.run_until(t)

    def wall_until_next(self, cap_s: float = 0.05) -> float:
        """Seconds of wall time before the robot's next event (at most ``cap_s``)."""
        nxt = self.emu.next_event_ns()
        if nxt is None:
            return cap_s
        dt = (nxt - self.target_ns()) / NS_PER_S / self.factor
        return min(max(dt, 0.0), cap_s)
