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
import queue
import threading
import time
from dataclasses import dataclass, field
from typing import Any, Callable

from .errors import ControlError, TransportError
from .spec import Spec
from .transport import codec

log = logging.getLogger("esair_std.bs")


@dataclass
class Record:
    spec: Spec
    host: Any
    generation: int = 1
    restarts: int = 0
    failures: list = field(default_factory=list)
    reason: str = ""
    handled: int = 0           # the last generation whose failure was handled


class _Starting:
    """The host of a record whose component is still being started."""

    def __init__(self, state: str = "starting", reason: str = ""):
        self.state = state
        self.reason = reason

    def offer(self, sender: str, data: Any) -> str:
        return self.state

    def provide(self, requester: str, timeout: float) -> tuple:
        return ("busy", "starting")

    def notify_detached(self, resource: str) -> None:
        pass

    def set_enabled(self, enabled: bool) -> None:
        pass

    def check(self, now: float) -> None:
        pass

    def counters(self) -> dict:
        return {}

    def stop(self, timeout: float = 0.0) -> None:
        pass


class BehaviorSupervisor:
    def __init__(self, start_host: Callable[[Spec, int], Any], rs: Any):
        self._start_host = start_host       # mode: (spec, generation) -> started host
        self._rs = rs
        self.records: dict[str, Record] = {}
        self._requests: queue.Queue = queue.Queue(maxsize=256)
        self._thread = threading.Thread(target=self._main, name="esair:bs", daemon=True)
        self._closing = False
        self.c = dict(puts_ok=0, puts_failed=0, gets_ok=0, gets_failed=0, restarts=0)

    # ---- phases 1-2
    def start(self) -> None:
        self._thread.start()

    def add(self, spec: Spec) -> Record:
        """Phase 1 calls this directly; later requests go through ``request``."""
        if spec.name in self.records:
            raise ControlError(f"a {self.records[spec.name].spec.kind} named {spec.name!r}"
                               " is already deployed")
        if spec.name in self._rs.resources or spec.name in self._rs.entries:
            raise ControlError(f"a resource named {spec.name!r} is already deployed")
        rec = Record(spec, _Starting())
        self.records[spec.name] = rec       # known before its start() asks for resources
        try:
            host = rec.host = self._start_host(spec, 1)
        except BaseException:
            self.records.pop(spec.name, None)
            raise
        if host.state == "failed":
            self._failed(spec.name, 1, host.reason)
        return rec

    def remove(self, name: str) -> None:
        rec = self.records.get(name)
        if rec is None:
            raise ControlError(f"no behavior or reaction {name!r}"
                               f"{_hint(name, list(self.records))}")
        del self.records[name]
        self._rs.release(name)
        rec.host.stop()

    def request(self, fn: Callable[..., Any], *args: Any, timeout: float = 30.0) -> Any:
        """Run ``fn(*args)`` on the BS thread (one request at a time); its result."""
        done = threading.Event()
        box: list = []
        try:
            self._requests.put((fn, args, box, done), timeout=1.0)
        except queue.Full:
            raise ControlError("the behavior supervisor is busy: try again") from None
        if not done.wait(timeout):
            raise ControlError(f"request not done within {timeout:g} s")
        ok, value = box[0]
        if not ok:
            raise value
        return value

    def failed(self, name: str, generation: int, reason: str) -> None:
        """A host reports its component failed (any thread): queued for the BS thread."""
        try:
            self._requests.put((self._failed, (name, generation, reason), None, None),
                               timeout=1.0)
        except queue.Full:
            log.error("failure of %s not queued: supervisor queue full", name)

    def stop_all(self) -> None:
        self._closing = True
        try:
            self._requests.put_nowait(None)
        except queue.Full:
            pass
        for name in reversed(list(self.records)):
            rec = self.records.pop(name)
            self._rs.release(name)
            rec.host.stop()
        if self._thread.is_alive():
            self._thread.join(2.0)

    def _main(self) -> None:
        while True:
            item = self._requests.get()
            if item is None or self._closing:
                return
            fn, args, box, done = item
            try:
                value = (True, fn(*args))
            except Exception as exc:  # noqa: BLE001 - handed to the requester
                value = (False, exc)
            if box is not None:
                box.append(value)
                done.set()
            elif not value[0]:
                log.error("supervisor: %s", value[1])

    def _failed(self, name: str, generation: int, reason: str) -> None:
        rec = self.records.get(name)
        if rec is None or rec.generation != generation or self._closing:
            return
        if rec.handled >= generation:
            return
        rec.handled = generation
        rec.reason = reason
        self._rs.release(name)
        rec.host.stop(0.2)
        now = time.monotonic()
        rec.failures = [t for t in rec.failures if now - t <= rec.spec.restart_within]
        if len(rec.failures) >= rec.spec.restart_max:
            log.warning("%s failed (%s); stays failed", name, reason)
            return
        rec.failures.append(now)
        rec.restarts += 1
        self.c["restarts"] += 1
        rec.generation += 1
        log.warning("%s failed (%s); restart %d", name, reason, rec.restarts)
        rec.host = _Starting()
        try:
            rec.host = self._start_host(rec.spec, rec.generation)
        except Exception as exc:  # noqa: BLE001 - the restart itself failed: stays failed
            rec.reason = f"restart failed: {exc}"
            rec.host = _Starting("failed", rec.reason)
            log.error("%s: %s", name, rec.reason)
            return
        if rec.host.state == "failed":
            self._failed(name, rec.generation, rec.host.reason)

    # ---- phase 3: the mediator
    def _target(self, name: str) -> tuple[Record | None, str]:
        rec = self.records.get(name)
        if rec is None:
            return None, f"no behavior {name!r}{_hint(name, list(self.records))}"
        if rec.spec.kind != "behavior":
            return None, f"{name!r} is a reaction: it takes no data"
        return rec, ""

    def put(self, sender: str, target: str, data: Any, timeout: float) -> tuple[bool, str]:
        try:
            data = codec.copy(data)
        except TransportError as exc:
            self.c["puts_failed"] += 1
            return False, exc.message
        deadline = time.monotonic() + max(0.0, float(timeout))
        delay = 0.0005
        while True:
            rec, why = self._target(target)
            if rec is None:
                self.c["puts_failed"] += 1
                return False, why
            r = rec.host.offer(sender, data)
            if r == "delivered":
                self.c["puts_ok"] += 1
                return True, ""
            left = deadline - time.monotonic()
            if left <= 0:
                self.c["puts_failed"] += 1
                return False, f"{target!r} did not take the data within {timeout:g} s ({r})"
            time.sleep(min(delay, left))
            delay = min(delay * 2, 0.01)

    def put_wait(self, sender: str, target: str, data: Any, timeout: float) -> tuple[bool, str]:
        """A put whose sender waits until the target's receive() ran: (True, "") when it
        took the data, (False, why) when it refused it (raised Refused), failed, or took
        no data within ``timeout`` (retried while busy)."""
        try:
            data = codec.copy(data)
        except TransportError as exc:
            self.c["puts_failed"] += 1
            return False, exc.message
        deadline = time.monotonic() + max(0.0, float(timeout))
        delay = 0.0005
        while True:
            rec, why = self._target(target)
            if rec is None:
                self.c["puts_failed"] += 1
                return False, why
            take = getattr(rec.host, "take", None)     # None: still starting, or failed
            status, why = (take(sender, data, max(0.001, deadline - time.monotonic()))
                           if take is not None else ("busy", rec.host.state))
            if status == "ok":
                self.c["puts_ok"] += 1
                return True, ""
            left = deadline - time.monotonic()
            if status in ("refused", "failed") or left <= 0:
                self.c["puts_failed"] += 1
                if status == "refused":
                    return False, f"{target!r} refused it: {why}"
                if status == "failed":
                    return False, f"{target!r}: {why}"
                return False, f"{target!r} did not take the data within {timeout:g} s ({why})"
            time.sleep(min(delay, left))
            delay = min(delay * 2, 0.01)

    def put_first(self, sender: str, target: str, data: Any, timeout: float,
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
                self.c["puts_ok"] += 1
            done(r == "delivered")
        return rec.host.offer_async(sender, data, result, timeout)

    def get(self, requester: str, target: str, timeout: float) -> tuple[bool, Any]:
        deadline = time.monotonic() + max(0.0, float(timeout))
        delay = 0.0005
        while True:
            rec, why = self._target(target)
            if rec is None:
                self.c["gets_failed"] += 1
                return False, why
            status, value = rec.host.provide(requester, max(0.001, deadline - time.monotonic()))
            if status == "ok":
                self.c["gets_ok"] += 1
                return True, value
            left = deadline - time.monotonic()
            if status == "failed" or left <= 0:
                self.c["gets_failed"] += 1
                if status == "failed":
                    return False, f"{target!r}: {value}"
                return False, f"{target!r} gave no data within {timeout:g} s ({value})"
            time.sleep(min(delay, left))
            delay = min(delay * 2, 0.01)

    def state_of(self, name: str) -> str | None:
        rec = self.records.get(name)
        return rec.host.state if rec is not None else None

    def notify_detached(self, behavior: str, resource: str) -> None:
        rec = self.records.get(behavior)
        if rec is not None:
            rec.host.notify_detached(resource)

    def set_reaction(self, name: str, enabled: bool) -> None:
        rec = self.records.get(name)
        if rec is None or rec.spec.kind != "reaction":
            names = [n for n, r in self.records.items() if r.spec.kind == "reaction"]
            raise ControlError(f"no reaction {name!r}{_hint(name, names)}")
        rec.host.set_enabled(enabled)


def _hint(name: str, names: list[str]) -> str:
    close = difflib.get_close_matches(name, names, n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""
