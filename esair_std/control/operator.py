"""The operator at the control endpoint: read a sensor's latest sample, send one command
to an actuator (``esair std sample`` / ``esair std send``).

The operator is a principal of its own, named ``operator`` in a resource's ``allow``
(as the HMI is ``hmi``): a command is refused unless the actuator's ``allow`` grants the
operator ``command``; it is then registered with the RS like a behavior (listed in
``inspect``'s grants) and routed by the AC. Reading a sample needs no grant: the
operator observes what the robot reports.

Samples: the first request for a sensor starts keeping its newest sample (thread mode: an
SC attachment named ``operator`` keeping one sample; process mode: a subscription to the
sensor's key on the control session, whose callback only stores the sample). That
request waits for the next sample; later ones answer at once.
"""

from __future__ import annotations

import threading
from typing import TYPE_CHECKING

from ..connections import SensorHandle
from ..errors import ControlError, Refused
from ..level import Level, best_match
from ..policy import PRINCIPALS
from ..sample import Sample
from ..transport import keys
from ..transport.codec import JSON

if TYPE_CHECKING:  # pragma: no cover
    from ..runtime_view import RuntimeView

#: The principal name of the command line's operator in ``allow``.
OPERATOR = PRINCIPALS[0]


class Operator:
    """One runtime's operator paths (built by the control server on first use)."""

    def __init__(self, rt: RuntimeView, who: str = OPERATOR):
        self.rt = rt
        self.who = who
        self._lock = threading.Lock()
        # resource -> its handle (thread mode) / a box holding its latest sample
        self._watched: dict[str, SensorHandle | list[Sample | None]] = {}
        self._fresh = threading.Condition(self._lock)

    # ---- sample
    def sample(self, resource: str, timeout: float) -> Sample:
        """The newest sample of sensor ``resource`` (waits up to ``timeout`` for a first)."""
        self._need(resource, "sensor")
        with self._lock:
            if resource not in self._watched:
                self._watch(resource)
            got = self._fresh.wait_for(lambda: self._latest(resource) is not None, timeout)
            sample = self._latest(resource)
            if not got or sample is None:
                raise ControlError(f"sensor {resource!r} reported no sample within "
                                   f"{timeout:g} s")
            return sample

    def _latest(self, resource: str) -> Sample | None:
        box = self._watched.get(resource)
        if isinstance(box, SensorHandle):
            return box.latest()
        return box[0] if box else None

    def _watch(self, resource: str) -> None:
        rt = self.rt
        if rt.mode_name == "thread":
            lock = self._lock

            class _Told(SensorHandle):      # wakes a waiting request (never blocks long)
                def push(self, sample: Sample) -> None:
                    super().push(sample)
                    with lock:
                        fresh.notify_all()
            fresh = self._fresh
            handle = _Told(resource, 1, rt.rs.state_of)
            rt.sc.attach(self.who, resource, handle)
            self._watched[resource] = handle
            return
        box: list[Sample | None] = [None]
        self._watched[resource] = box

        def keep(obj: JSON) -> None:              # transport thread: store, notify, return
            try:
                sample = Sample.from_wire(obj)
            except Exception:  # noqa: BLE001 - garbage on the key is not a sample
                return
            with self._lock:
                box[0] = sample
                self._fresh.notify_all()
        bus = rt.server.bus if rt.server is not None else None
        if bus is None:
            raise ControlError("this runtime has no control endpoint to read sensors by")
        bus.subscribe(keys.sensor(rt.robot, resource), keep)

    # ---- send
    def send(self, resource: str, command: JSON, timeout: float) -> JSON:
        """Carry out one ``command`` on actuator ``resource`` as the operator; the
        actuator's answer. Refused unless its ``allow`` grants the operator command."""
        entry = self._need(resource, "actuator")
        allow = self.rt.rs.entries[entry][0].allow
        granted = best_match(allow, self.who)
        fix = f"add '{self.who}: command' to the allow of resource {entry!r}"
        if granted is None:
            raise Refused(f"{resource!r} does not allow the {self.who} ({fix})")
        if granted < Level.command:
            raise Refused(f"{resource!r} allows the {self.who} only up to {granted.name!r} "
                          f"({fix})")
        if self.rt.rs.granted(self.who, resource) < Level.command:
            self.rt.rs.register(self.who, resource, Level.command, None)
        return self.rt.ac.command(self.who, resource, command, timeout)

    def _need(self, resource: str, kind: str) -> str:
        """The entry of ``resource``, which must be a ``kind``; clear errors otherwise."""
        rs = self.rt.rs
        have = rs.kind_of(resource)
        if have is None:
            import difflib
            close = difflib.get_close_matches(resource, list(rs.resources), n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            if resource in rs.entries:
                kids = [r for r, (e, k) in rs.resources.items() if e == resource and k == kind]
                hint = (f" ({resource!r} is a driver; its {kind}s: {', '.join(kids)})" if kids
                        else f" ({resource!r} is a driver with no {kind})")
            raise ControlError(f"no {kind} {resource!r}{hint}")
        if have != kind:
            raise ControlError(f"{resource!r} is {'an' if have == 'actuator' else 'a'} {have}, "
                               f"not {'an' if kind == 'actuator' else 'a'} {kind}")
        return rs.resources[resource][0]
