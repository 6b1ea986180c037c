"""One generic supervisor, in the Erlang/OTP sense: the BS and the RS are both built on it.

A supervisor holds children described by declarative :class:`ChildSpec` s (restart
intensity ``max`` within a period ``within`` seconds, and what happens past that limit)
and runs every change to them — add, remove, a failure, a restart — one request at a
time on its own thread. A child's failure is an event on that queue (``failed``), never
an exception that travels. Its order of work is the same for behaviors and resources:

- **remove**: the child is stopped first (its own ``stop()`` runs while it still holds
  its registrations), then what it held is released (``released(name, "removed")``);
- **failure**: what it held is released (``released(name, "failed")``), the dead host is
  stopped, then — within the policy — it is started again as a new generation and
  ``restarted(name)`` is called; past the limit it stays failed (``past_limit="stay"``)
  or is dropped (``"remove"``).

Subclasses (bs.BehaviorSupervisor, rs.ResourceSupervisor) say how a host is started
and what "release" and "restarted" mean for their kind of child.
"""

from __future__ import annotations

import contextlib
import logging
import queue
import threading
import time
from typing import (TYPE_CHECKING, Callable, Generic, Literal, TypeVar, TypeVarTuple, Union,
                    Unpack, cast)

from esair_min import sigs

from .errors import ControlError
from .counters import Counters
from .restart_window import RestartWindow
from .spec import Spec
from .transport.codec import JSON, JSONObject

if TYPE_CHECKING:  # pragma: no cover
    from .parts import Child

H = TypeVar("H", bound="Child")     # the kind of host a supervisor's children have
_R = TypeVar("_R")
_Ts = TypeVarTuple("_Ts")
#: a request's outcome, as the supervisor's thread hands it back: (True, value) or
#: (False, the exception it raised)
_Outcome = Union[tuple[Literal[True], object], tuple[Literal[False], Exception]]
#: one item of the request queue: fn, its args, the box for its outcome (None: a failure
#: event, nobody waits) and the event that says it is there
_Item = tuple[Callable[..., object], tuple[object, ...], Union[list[_Outcome], None],
              Union[threading.Event, None]]

log = logging.getLogger("esair_std.supervisor")
REQUESTS = 256          # requests and failure events waiting for the supervisor's thread
PAST_LIMIT = ("stay", "remove")


class ChildSpec:
    """How a child is supervised: at most ``max`` restarts in any ``within`` seconds;
    past that, ``past_limit``: "stay" (failed, listed with its reason) or "remove".
    Immutable, compared by value. (A plain class, not a dataclass: ``dataclasses``
    imports ``inspect`` and ``ast`` into the robot side.)"""

    __slots__ = ("name", "kind", "max", "within", "past_limit")
    name: str
    kind: str
    max: int
    within: float
    past_limit: Literal["stay", "remove"]

    def __init__(self, name: str, kind: str, max: int = 0, within: float = 10.0,
                 past_limit: Literal["stay", "remove"] = "stay"):
        if past_limit not in PAST_LIMIT:
            raise ValueError(f"past_limit must be one of {PAST_LIMIT}, not {past_limit!r}")
        for key, value in zip(self.__slots__, (name, kind, max, within, past_limit)):
            object.__setattr__(self, key, value)

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError(f"cannot assign to field {name!r} of ChildSpec")

    def _values(self) -> tuple[object, ...]:
        return tuple(getattr(self, k) for k in self.__slots__)

    def __eq__(self, other: object) -> bool:
        if type(other) is not ChildSpec:
            return NotImplemented
        return self._values() == other._values()

    def __hash__(self) -> int:
        return hash(self._values())

    def __repr__(self) -> str:
        return "ChildSpec(" + ", ".join(f"{k}={getattr(self, k)!r}" for k in self.__slots__) + ")"

    @classmethod
    def of(cls, spec: Spec) -> "ChildSpec":
        """The child spec of a component Spec (its ``restart: {max, within}``)."""
        return cls(spec.name, spec.kind, int(spec.restart_max or 0),
                   float(spec.restart_within or 0.0))


class Starting:
    """The host of a child that is still being started (or could not be restarted)."""

    def __init__(self, state: str = "starting", reason: str = ""):
        self.state = state
        self.phase = state
        self.reason = reason

    def offer(self, sender: str, data: JSON) -> str:
        return self.state

    def provide(self, requester: str, timeout: float) -> tuple[str, JSON]:
        return ("busy", self.state)

    def notify_detached(self, resource: str) -> None:
        pass

    def notify_attached(self, resource: str) -> None:
        pass

    def set_enabled(self, enabled: bool) -> None:
        pass

    def notify_latch(self, state: JSONObject | None, by: str = "") -> None:
        pass

    def halt(self, why: str) -> None:
        pass              # the RS halts it once it has started (rs.py: add, restarted)

    def release(self) -> None:
        pass

    def check(self, now: float) -> float | None:
        return None

    def children(self) -> dict[str, str]:
        return {}

    def counters(self) -> JSONObject:
        return {}

    def grant(self, who: str, resource: str) -> None:
        pass

    def revoke(self, who: str, resource: str | None = None) -> None:
        pass

    def stop(self, timeout: float = 0.0) -> None:
        pass


class Record(Generic[H]):
    """A supervised child: its component spec, its host (or a stand-in while it
    starts), its restart history."""

    def __init__(self, spec: Spec, host: H | Starting, child: ChildSpec | None = None,
                 generation: int = 1, restarts: int = 0, window: RestartWindow | None = None,
                 reason: str = "", handled: int = 0, removing: bool = False):
        self.spec = spec
        self.host = host
        self.child: ChildSpec | None = ChildSpec.of(spec) if child is None else child
        self.generation = generation
        self.restarts = restarts
        self.window: RestartWindow | None = (RestartWindow(self.child.max, self.child.within)
                                             if window is None else window)
        self.reason = reason
        self.handled = handled      # the last generation whose failure was handled
        self.removing = removing    # being removed: its failures are no longer events


class Supervisor(Generic[H]):
    """Children by name, one request at a time on the thread ``esair:<name>``."""

    #: remove: release what the child holds before stopping it (True: the RS, so a
    #: device being closed takes no new command) or after (False: the BS, so a
    #: behavior's stop() still reaches what it registered for)
    release_before_stop = False

    def __init__(self, name: str, start_host: Callable[[Spec, int], H]):
        self._start_host = start_host      # (component spec, generation) -> started host
        self.records: dict[str, Record[H]] = {}
        self._requests: queue.Queue[_Item | None] = queue.Queue(maxsize=REQUESTS)
        self._thread = threading.Thread(target=self._main, name=f"esair:{name}", daemon=True)
        self._closing = False
        self.c = Counters(restarts=0)
        self.on_change: Callable[[], None] = lambda: None   # a child's state changed

    # ---- what a subclass says
    def released(self, name: str, rec: Record[H], why: str) -> None:
        """``rec`` no longer holds anything (why: "removed" after its stop, "failed")."""

    def restarted(self, name: str, rec: Record[H]) -> None:
        """``rec`` runs again as generation ``rec.generation``."""

    def gave_up(self, name: str, rec: Record[H]) -> None:
        """``rec`` failed past its restart limit."""

    # ---- requests
    def start(self) -> None:
        if not self._thread.is_alive():
            self._thread.start()

    def request(self, fn: Callable[[Unpack[_Ts]], _R], *args: Unpack[_Ts],
                timeout: float = 30.0) -> _R:
        """Run ``fn(*args)`` on the supervisor's thread (one request at a time); its result.
        Before ``start`` (phase 1) or on that thread itself, it runs here."""
        if self._closing:
            raise ControlError("the runtime is stopping")
        if not self._thread.is_alive() or threading.current_thread() is self._thread:
            return fn(*args)
        done = threading.Event()
        box: list[_Outcome] = []
        try:
            self._requests.put((fn, args, box, done), timeout=1.0)
        except queue.Full:
            raise ControlError("the supervisor is busy: try again") from None
        if not sigs.wait(done, timeout):    # the main thread's signals interrupt it
            raise ControlError(f"request not done within {timeout:g} s")
        outcome = box[0]
        if outcome[0] is False:
            raise outcome[1]
        return cast(_R, outcome[1])         # what fn returned (_main)

    def add_child(self, spec: Spec) -> Record[H]:
        """Start ``spec`` as generation 1 (on the supervisor's thread, or in phase 1)."""
        rec: Record[H] = Record(spec, Starting())
        self.records[spec.name] = rec       # known before its start() asks for anything
        try:
            host = rec.host = self._start_host(spec, 1)
        except BaseException:
            self.records.pop(spec.name, None)
            raise
        if _state(host) == "failed":
            self._failed(spec.name, 1, getattr(host, "reason", ""))
        self.on_change()
        return rec

    def remove_child(self, name: str) -> Record[H]:
        """Stop, release and forget the child (in the order ``release_before_stop``
        says)."""
        rec = self.records[name]
        self._stop_child(name, rec)
        self.on_change()
        return rec

    def _stop_child(self, name: str, rec: Record[H]) -> None:
        rec.removing = True
        if self.release_before_stop:
            self.records.pop(name, None)
            try:
                self.released(name, rec, "removed")
            finally:
                rec.host.stop()
            return
        try:
            rec.host.stop()
        finally:
            self.records.pop(name, None)
            self.released(name, rec, "removed")

    def failed(self, name: str, generation: int, reason: str) -> None:
        """A host reports its child failed (any thread): queued for the supervisor."""
        try:
            self._requests.put((self._failed, (name, generation, reason), None, None),
                               timeout=1.0)
        except queue.Full:
            log.error("failure of %s not queued: supervisor queue full", name)

    def stop_children(self) -> None:
        """Every child stopped, the newest first; then the thread ends."""
        self._closing = True
        with contextlib.suppress(queue.Full):
            self._requests.put_nowait(None)
        if self._thread.is_alive() and threading.current_thread() is not self._thread:
            self._thread.join(5.0)          # a restart under way finishes first
        for name in reversed(list(self.records)):
            rec = self.records.get(name)
            if rec is not None:
                self._stop_child(name, rec)

    # ---- the thread
    def _main(self) -> None:
        while True:
            item = self._requests.get()
            if item is None or self._closing:
                return
            fn, args, box, done = item
            value: _Outcome
            try:
                value = (True, fn(*args))
            except Exception as exc:  # noqa: BLE001 - handed to the requester
                value = (False, exc)
            if box is not None and done is not None:
                box.append(value)
                done.set()
            elif not value[0]:
                log.error("supervisor: %s", value[1])

    def _failed(self, name: str, generation: int, reason: str) -> None:
        try:
            self._fail(name, generation, reason)
        finally:
            self.on_change()

    def _fail(self, name: str, generation: int, reason: str) -> None:
        rec = self.records.get(name)
        if (rec is None or rec.generation != generation or self._closing or rec.removing
                or rec.handled >= generation):
            return
        rec.handled = generation
        rec.reason = reason
        self.released(name, rec, "failed")
        rec.host.stop(0.2)
        now = time.monotonic()
        child = rec.child
        assert child is not None                 # set by Record.__post_init__
        assert rec.window is not None               # set by Record.__post_init__
        if not rec.window.allow(now):
            log.warning("%s failed (%s); stays failed", name, reason)
            if child.past_limit == "remove":
                self.records.pop(name, None)
            self.gave_up(name, rec)
            return
        rec.restarts += 1
        self.c.add("restarts")
        rec.generation += 1
        log.warning("%s failed (%s); restart %d", name, reason, rec.restarts)
        rec.host = Starting()
        try:
            rec.host = self._start_host(rec.spec, rec.generation)
        except Exception as exc:  # noqa: BLE001 - the restart itself failed: stays failed
            rec.reason = f"restart failed: {exc}"
            rec.handled = rec.generation         # no later event of it restarts it again
            rec.host = Starting("failed", rec.reason)
            log.error("%s: %s", name, rec.reason)
            self.gave_up(name, rec)
            return
        if self._closing:                   # stopped while it restarted
            rec.host.stop()
            return
        if _state(rec.host) == "failed":
            self._fail(name, rec.generation, getattr(rec.host, "reason", ""))
            return
        self.restarted(name, rec)


def _state(host: object) -> str:
    return str(getattr(host, "state", ""))
