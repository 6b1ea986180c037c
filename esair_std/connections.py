"""Sensor Connection (SC) and Actuator Connection (AC), and the behavior's ends of them.

SC: routes each sensor's samples to every attached behavior (many per sensor); a sample
no attached behavior asked for is not kept. Attaching needs a granted registration.
AC: routes commands of attached behaviors to actuators; no memory, no arbitration.
Attaching needs a registration at ``command`` level.

Thread mode: the SC routes samples itself (``route``), the AC forwards to the actuator's
host. Process mode: samples travel straight from the sensor's process to subscribed
behaviors and commands straight to the actuator's process (the data flow does not pass
the runtime); the SC/AC tables here are still the ones consulted and listed, and the RS
pushes every grant/revoke to the actuator's host, which checks each command against it.
"""

from __future__ import annotations

import threading
from collections import deque
from typing import TYPE_CHECKING, Any, Callable, cast

from .errors import CommandError, Refused, ResourceLost, StdError
from .level import Level
from .sample import Sample
from .transport.codec import JSON

if TYPE_CHECKING:  # pragma: no cover
    from .parts import Grants, SampleHandle


class _Handle:
    """What a behavior's two ends share: the resource's state as it sees it."""

    resource: str
    detached: bool
    _state_fn: Callable[[str], str | None]

    @property
    def state(self) -> str:
        if self.detached:
            return "detached"
        return self._state_fn(self.resource) or "gone"


class SensorHandle(_Handle):
    """A behavior's end of the SC for one sensor: a bounded buffer of samples."""

    def __init__(self, resource: str, keep: int, state_fn: Callable[[str], str | None]):
        self.resource = resource
        self._buf: deque[Sample] = deque(maxlen=max(1, int(keep)))
        self._lock = threading.Lock()
        self._latest: Sample | None = None
        self._state_fn = state_fn
        self.received = 0          # samples that reached this handle
        self.overwritten = 0       # samples dropped because samples() was not called in time
        # samples the sensor numbered between two that reached this handle but that never
        # did (its link was down: a process stopped longer than the link lease, a cut)
        self.missed = 0
        self._seq: int | None = None
        self._draining = False     # samples() was called: the reader wants every sample
        self.detached = False

    def push(self, sample: Sample) -> None:
        """Called by the connection (never user code); O(1), never blocks."""
        if self.detached:
            return
        with self._lock:
            if self._seq is not None and sample.seq > self._seq + 1:
                self.missed += sample.seq - self._seq - 1
            self._seq = sample.seq         # a restarted sensor numbers from 1 again
            if len(self._buf) == self._buf.maxlen and self._draining:
                self.overwritten += 1
            self._buf.append(sample)
            self._latest = sample
            self.received += 1

    def latest(self) -> Sample | None:
        """The newest sample, or None before the first."""
        return self._latest

    def samples(self) -> list[Sample]:
        """Every sample that arrived since the last call (oldest first), at most ``keep``."""
        with self._lock:
            self._draining = True
            out = list(self._buf)
            self._buf.clear()
        return out

    def counters(self) -> dict[str, int]:
        return {"received": self.received, "overwritten": self.overwritten,
                "missed": self.missed}


class ActuatorHandle(_Handle):
    """A behavior's end of the AC for one actuator."""

    def __init__(self, resource: str, send_fn: Callable[[str, JSON, float], JSON],
                 state_fn: Callable[[str], str | None]):
        self.resource = resource
        self._send = send_fn
        self._state_fn = state_fn
        self.sent = 0
        self.failed = 0
        self.detached = False

    def send(self, command: object, timeout: float = 1.0) -> Any:
        """The actuator's ``write()`` result. Raises only CommandError (the actuator
        refused or failed it, no answer within ``timeout``, or the sender is not, or no
        longer, registered to command it: "refused: ...") or ResourceLost (removed,
        lost, its host gone)."""
        if self.detached:
            self.failed += 1
            raise ResourceLost(self.resource, "detached: the resource was removed")
        try:
            # JSON, checked where it is copied or encoded (else TransportError, below)
            result = self._send(self.resource, cast(JSON, command), timeout)
        except (CommandError, ResourceLost):
            self.failed += 1
            raise
        except StdError as exc:       # Refused, a command that is not JSON (TransportError)
            self.failed += 1
            why = f"refused: {exc.message}" if isinstance(exc, Refused) else exc.message
            raise CommandError(self.resource, why) from None
        self.sent += 1
        return result

    def counters(self) -> dict[str, int]:
        return {"sent": self.sent, "failed": self.failed}


class SensorConnection:
    """Who is attached to which sensor; in thread mode also the router."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._attached: dict[str, dict[str, SampleHandle | None]] = {}
        self._parked: dict[str, dict[str, SampleHandle | None]] = {}   # removed sensors
        self.routed = 0
        self.unrouted = 0    # samples with nobody attached: not kept

    def attach(self, behavior: str, resource: str, handle: SampleHandle | None) -> None:
        with self._lock:
            self._attached.setdefault(resource, {})[f"{behavior}#{id(handle)}"] = handle

    def detach(self, behavior: str, resource: str | None = None) -> list[str]:
        """Detach ``behavior`` from ``resource`` (or from every sensor)."""
        gone = []
        with self._lock:
            for res, table in self._attached.items():
                if resource is not None and res != resource:
                    continue
                for key in [k for k in table if k.split("#")[0] == behavior]:
                    h = table.pop(key)
                    if h is not None:
                        h.detached = True
                    gone.append(res)
        return gone

    def drop_resource(self, resource: str) -> list[str]:
        """The sensor is removed: every handle detached; returns the behaviors."""
        with self._lock:
            table = self._attached.pop(resource, {})
            if table:
                self._parked[resource] = dict(table)
        for h in table.values():
            if h is not None:
                h.detached = True
        return sorted({k.split("#")[0] for k in table})

    def restore(self, behavior: str, resource: str) -> None:
        """The sensor is back (added again): ``behavior``'s handles attached again."""
        with self._lock:
            parked = self._parked.get(resource, {})
            keys = [k for k in parked if k.split("#")[0] == behavior]
            table = self._attached.setdefault(resource, {})
            for key in keys:
                h = table[key] = parked.pop(key)
                if h is not None:
                    h.detached = False
            if not parked:
                self._parked.pop(resource, None)
            if not keys:                      # nothing parked (process mode): just listed
                table[f"{behavior}#0"] = None

    def forget(self, behavior: str) -> None:
        """``behavior`` is gone: nothing of it kept for sensors that come back."""
        with self._lock:
            for res in list(self._parked):
                table = self._parked[res]
                for key in [k for k in table if k.split("#")[0] == behavior]:
                    del table[key]
                if not table:
                    del self._parked[res]

    def attached_to(self, resource: str) -> list[str]:
        with self._lock:
            return sorted({k.split("#")[0] for k in self._attached.get(resource, {})})

    def route(self, resource: str, sample: Sample) -> None:
        """Thread mode: hand the sample to every attached handle (never blocks)."""
        table = self._attached.get(resource)
        if not table:
            self.unrouted += 1
            return
        for h in list(table.values()):
            if h is not None:
                h.push(sample)
        self.routed += 1


class ActuatorConnection:
    """Routes commands of attached behaviors; checks the RS's registration table."""

    def __init__(self, rs: Grants) -> None:
        self._rs = rs
        self.routed = 0
        self.refused = 0

    def check(self, sender: str, resource: str) -> None:
        if self._rs.granted(sender, resource) < Level.command:
            self.refused += 1
            raise Refused(f"behavior {sender!r} is not registered to command {resource!r}")

    def command(self, sender: str, resource: str, command: JSON, timeout: float,
                direct: bool = False) -> JSON:
        if not direct:
            self.check(sender, resource)
        host = self._rs.host_of(resource)
        self.routed += 1
        return host.command(sender, resource, command, timeout)
