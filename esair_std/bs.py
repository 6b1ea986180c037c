"""Behavior Supervisor (BS), thesis 3.4 — a supervisor in the Erlang/OTP sense.

Phase 1: starts the deployment's behaviors (and reactions) in order. Phase 2
(WAIT_REQUEST): adds, removes and restarts them one request at a time, on its own
thread; a child's failure is an event on that queue, never an exception that travels.
Restart policy: at most ``restart_max`` restarts within ``restart_within`` seconds,
then the behavior stays failed. Phase 3, the mediator: ``put``/``get``/``state``
between behaviors, retrying while the target is busy until the timeout, then
reporting the failure — never a silent loss, never an endless wait.
"""

from __future__ import annotations

import difflib
import logging
import time
from typing import TYPE_CHECKING, Callable, TypeVar

from .errors import ControlError, TransportError
from .spec import Spec
from .supervisor import Record, Supervisor
from .transport import codec
from .transport.codec import JSON, JSONObject
from .parts import NO_ANSWER, ComponentHost

if TYPE_CHECKING:  # pragma: no cover
    from .parts import Registry

log = logging.getLogger("esair_std.bs")
_V = TypeVar("_V")      # what a mediator's attempt answers with


class BehaviorSupervisor(Supervisor[ComponentHost]):
    """Behaviors and reactions on the generic supervisor (supervisor.py), plus the
    mediator (phase 3)."""

    def __init__(self, start_host: Callable[[Spec, int], ComponentHost], rs: Registry,
                 forget: Callable[[str], None] | None = None):
        super().__init__("bs", start_host)   # mode: (spec, generation) -> started host
        self._rs = rs
        self._forget = forget or (lambda _name: None)   # the mode's tables for a name
        self.c.update(puts_ok=0, puts_failed=0, gets_ok=0, gets_failed=0)

    # ---- phases 1-2
    def add(self, spec: Spec) -> Record[ComponentHost]:
        """Phase 1 calls this directly; later requests go through ``request``."""
        if spec.name in self.records:
            raise ControlError(f"a {self.records[spec.name].spec.kind} named {spec.name!r}"
                               " is already deployed")
        if self._rs.knows(spec.name):
            raise ControlError(f"a resource named {spec.name!r} is already deployed")
        return self.add_child(spec)

    def remove(self, name: str) -> None:
        """Stop first (the behavior's stop() runs with its registrations), then release."""
        if name not in self.records:
            raise ControlError(f"no behavior or reaction {name!r}"
                               f"{_hint(name, list(self.records))}")
        self.remove_child(name)

    def stop_all(self) -> None:
        self.stop_children()

    def released(self, name: str, rec: Record[ComponentHost], why: str) -> None:
        self._rs.release(name)
        if why == "removed":
            self._forget(name)

    # ---- phase 3: the mediator
    def _target(self, name: str) -> tuple[Record[ComponentHost] | None, str]:
        rec = self.records.get(name)
        if rec is None:
            return None, f"no behavior {name!r}{_hint(name, list(self.records))}"
        if rec.spec.kind != "behavior":
            return None, f"{name!r} is a reaction: it takes no data"
        return rec, ""

    def _until(self, counter: str, target: str, timeout: float, late: str,
               attempt: Callable[[Record[ComponentHost], float], tuple[str, _V]],
               ) -> tuple[bool, _V | str]:
        """The mediator's one retry loop: ``attempt(record, seconds left)`` answers
        ("ok", value), ("final", why) to give up now, or (anything else, why) while the
        target is busy; retried (backoff 0.5 ms doubling to 10 ms) until ``timeout``.
        Counts ``<counter>_ok`` / ``<counter>_failed``; a late failure says
        "<target> <late> within <timeout> s (<why>)"."""
        deadline = time.monotonic() + max(0.0, float(timeout))
        delay = 0.0005
        said: _V | str | None = None     # the target's own last reason (not "no answer")
        while True:
            rec, why = self._target(target)
            status, value = (("final", why) if rec is None else
                             attempt(rec, max(0.001, deadline - time.monotonic())))
            if status == "ok":
                self.c.add(counter + "_ok")
                return True, value
            if value != NO_ANSWER:
                said = value
            left = deadline - time.monotonic()
            if status == "final" or left <= 0:
                self.c.add(counter + "_failed")
                return False, (value if status == "final" else
                               f"{target!r} {late} within {timeout:g} s "
                               f"({value if said is None else said})")
            time.sleep(min(delay, left))
            delay = min(delay * 2, 0.01)

    def _copied(self, data: object) -> tuple[bool, JSON]:
        try:
            return True, codec.copy(data)
        except TransportError as exc:
            self.c.add("puts_failed")
            return False, exc.message

    def put(self, sender: str, target: str, data: object, timeout: float) -> tuple[bool, str]:
        ok, data = self._copied(data)
        if not ok:
            return False, str(data)

        def offer(rec: Record[ComponentHost], _left: float) -> tuple[str, str]:
            r = rec.host.offer(sender, data)
            return ("ok", "") if r == "delivered" else ("busy", r)
        return self._until("puts", target, timeout, "did not take the data", offer)

    def put_wait(self, sender: str, target: str, data: object,
                 timeout: float) -> tuple[bool, str]:
        """A put whose sender waits until the target's receive() ran: (True, "") when it
        took the data, (False, why) when it refused it (raised Refused), failed, or took
        no data within ``timeout`` (retried while busy)."""
        ok, data = self._copied(data)
        if not ok:
            return False, str(data)

        def take(rec: Record[ComponentHost], left: float) -> tuple[str, str]:
            taker = getattr(rec.host, "take", None)     # None: still starting, or failed
            if taker is None:
                return "busy", rec.host.state
            status, why = taker(sender, data, left)
            if status == "refused":
                return "final", f"{target!r} refused it: {why}"
            if status == "failed":
                return "final", f"{target!r}: {why}"
            return status, ("" if status == "ok" else why)
        return self._until("puts", target, timeout, "did not take the data", take)

    def put_first(self, sender: str, target: str, data: JSON, timeout: float,
                  done: Callable[[bool], None]) -> bool:
        """Process mode's fast path: the first offer without blocking a thread.
        ``data`` was decoded from the wire just now (it is a copy already). False: not
        tried (use ``put``). Else ``done(delivered)`` is called once, from a transport
        thread, within ``timeout``; when not delivered, the caller goes on with ``put``
        (retries until the rest of the timeout)."""
        rec, _why = self._target(target)
        if rec is None or not hasattr(rec.host, "offer_async"):
            return False

        def result(r: str) -> None:
            if r == "delivered":
                self.c.add("puts_ok")
            done(r == "delivered")
        return bool(rec.host.offer_async(sender, data, result, timeout))

    def get(self, requester: str, target: str, timeout: float) -> tuple[bool, JSON]:
        def provide(rec: Record[ComponentHost], left: float) -> tuple[str, JSON]:
            status, value = rec.host.provide(requester, left)
            return ("final", f"{target!r}: {value}") if status == "failed" else (status, value)
        return self._until("gets", target, timeout, "gave no data", provide)

    def state_of(self, name: str) -> str | None:
        rec = self.records.get(name)
        return rec.host.state if rec is not None else None

    def notify_detached(self, behavior: str, resource: str) -> None:
        rec = self.records.get(behavior)
        if rec is not None:
            rec.host.notify_detached(resource)

    def notify_latch(self, state: JSONObject | None, by: str = "") -> None:
        """The robot was STOPPED (``state``) or released (None, by ``by``): every
        behavior and reaction told (``robot_stopped`` / ``robot_released``)."""
        for name, rec in list(self.records.items()):
            try:
                rec.host.notify_latch(state, by)
            except Exception as exc:  # noqa: BLE001 - the others are told anyway
                log.warning("%s: not told of the STOP: %s", name, exc)

    def notify_attached(self, behavior: str, resource: str) -> None:
        """``resource`` is back (restarted or added again): the behavior's handles to it
        work again."""
        rec = self.records.get(behavior)
        if rec is not None:
            rec.host.notify_attached(resource)

    def set_reaction(self, name: str, enabled: bool) -> None:
        rec = self.records.get(name)
        if rec is None or rec.spec.kind != "reaction":
            names = [n for n, r in self.records.items() if r.spec.kind == "reaction"]
            raise ControlError(f"no reaction {name!r}{_hint(name, names)}")
        rec.host.set_enabled(enabled)


def _hint(name: str, names: list[str]) -> str:
    close = difflib.get_close_matches(name, names, n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""
