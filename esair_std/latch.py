"""The latched STOP (docs/std.md, "The latched stop"): the runtime's one STOPPED state.

ISO 13850's rule: a stop latches, overrides every other command source, and only a
person's deliberate reset ends it; the reset by itself starts nothing. Here the state
is who stopped the robot, when and why; while it holds, every resource host refuses
every actuator command with :meth:`Latch.refusal`'s text. Who may stop: the operator
(the command line, the Python API), the HMI, a behavior whose entry says ``may_stop:
true``. Who may release: the operator only (the HMI's operators act as the operator).
"""

from __future__ import annotations

import threading
import time
from typing import TYPE_CHECKING, Mapping, cast

from .errors import ControlError, Refused
from .transport.codec import JSONObject

if TYPE_CHECKING:  # pragma: no cover
    from .parts import ComponentHost
    from .supervisor import Record

#: what a refused command's sender reads (by, at as HH:MM:SS local time)
REFUSAL = "stopped by {by} at {at}: release with esair std release"


def refusal(state: JSONObject) -> str:
    """The text every refused command gets while ``state`` (a STOP) holds."""
    return REFUSAL.format(by=state["by"], at=clock(cast(float, state["t"])))  # Latch.stop's


def may_stop(records: Mapping[str, Record[ComponentHost]], who: str) -> None:
    """Refused unless ``who`` is no deployed component (``records``: the BS's), or one
    whose entry grants it the STOP (``may_stop: true``)."""
    rec = records.get(who)
    if rec is not None and rec.spec.options.get("may_stop") is not True:
        raise Refused(f"{rec.spec.kind} {who!r} may not STOP the robot (its deployment "
                      f"entry would say 'may_stop: true')")


def clock(t: float) -> str:
    return time.strftime("%H:%M:%S", time.localtime(t))


class Latch:
    """The STOPPED state: None while running, else ``{by, t, reason, at, n}`` (``at``
    the local time as text, ``n`` the STOPs so far). Thread-safe."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.state: JSONObject | None = None
        self.stops = 0          # STOPs ever (a second STOP while stopped counts too)
        self.releases = 0

    def stop(self, by: str, reason: str = "") -> tuple[JSONObject, bool]:
        """Latch (or stay latched: the first STOP's who and when are kept); the state
        and whether this STOP latched it."""
        with self._lock:
            self.stops += 1
            if self.state is not None:
                return dict(self.state), False
            t = time.time()
            self.state = {"by": by, "t": t, "at": clock(t), "reason": reason,
                          "n": self.stops}
            return dict(self.state), True

    def release(self, by: str) -> JSONObject:
        """Unlatch; the STOP that held. ControlError when none does."""
        with self._lock:
            if self.state is None:
                raise ControlError("the robot is not stopped: nothing to release")
            was, self.state = self.state, None
            self.releases += 1
        return dict(was, released_by=by)

    def get(self) -> JSONObject | None:
        with self._lock:
            return None if self.state is None else dict(self.state)
