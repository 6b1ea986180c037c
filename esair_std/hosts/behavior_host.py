"""The host of one behavior or reaction: its own thread, one bounded mailbox.

Used as is in thread mode (the runtime holds the host) and inside an agent process in
process mode (the agent holds it). Everything the component asks of the runtime goes
through ``port`` (LocalPort or the agent's ZenohPort); every call into user code runs
on the host's thread, never on the caller's or a transport thread.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections import deque
from typing import TYPE_CHECKING, Callable, Literal, TypeVar, TypeVarTuple, Union, Unpack, cast

from ..behavior import Behavior, _Component
from ..connections import ActuatorHandle, SensorHandle
from ..errors import Refused
from ..level import Level
from ..spec import Spec

if TYPE_CHECKING:  # pragma: no cover
    from ..parts import Port
from ..transport import codec
from ..transport.codec import JSON, JSONObject
from ..counters import Counters

INBOX = 64          # deliveries + provide requests waiting for the behavior's thread
RESERVED = 16       # more mailbox slots, reserved for the BS's deliveries into room
                    # (process mode: modes/process.py, ComponentHost.deliver_reserved)
NOTICES = 64        # detach notices waiting for the behavior's thread

log = logging.getLogger("esair_std.host")
_T = TypeVar("_T")
_R = TypeVar("_R")
_Ts = TypeVarTuple("_Ts")
#: (status, value) of a provide() or a take: ("ok", data), ("busy" | "failed" |
#: "refused", why)
Outcome = tuple[str, JSON]
Reply = Callable[[Outcome], None]
#: a mailbox item: a delivery (offered or into reserved room), a put whose sender waits
#: for receive(), a provide() request
_Item = Union[tuple[Literal["deliver", "reserved"], str, JSON],
              tuple[Literal["take"], str, tuple[JSON, Reply]],
              tuple[Literal["provide"], str, Reply]]
#: a notice for the component's thread: a detached resource, or the latch's change
_Notice = Union[str, tuple[str, Union[JSONObject, None], str]]


class _Reply:
    """A one-shot answer slot for a provide() request."""

    def __init__(self) -> None:
        self._ev = threading.Event()
        self.value: Outcome = ("busy", "no answer")

    def __call__(self, value: Outcome) -> None:
        self.value = value
        self._ev.set()

    def wait(self, timeout: float) -> bool:
        return self._ev.wait(timeout)


class _Abandoned(BaseException):
    """Raised on an abandoned host's thread to leave without touching anything."""


def build(cls: type[_T], host: object) -> _T:
    """An instance of a user class with its host set before the user's __init__ runs."""
    obj = cls.__new__(cls)
    setattr(obj, "_esair", host)  # noqa: B010 - no class of _T declares it
    cls.__init__(obj)
    return obj


class ComponentHost:
    """Runs one Behavior (or Reaction) object: life cycle, mailbox, counters."""

    def __init__(self, spec: Spec, cls: type[_Component], port: Port, generation: int = 1):
        self.spec = spec
        self.name = spec.name
        self.kind = spec.kind
        self.cls = cls
        self.port = port
        self.generation = generation
        self.inbox: queue.Queue[_Item] = queue.Queue(maxsize=INBOX + RESERVED)
        self._reserved_in = 0          # reserved slots in use (their items in inbox)
        self.taken = 0                 # reserved deliveries taken out, ever
        self._told_taken = 0           # ``taken`` when on_room was last called
        self._told_full = False        # ``full`` when on_room was last called
        self._report_lock = threading.Lock()   # one report at a time, the last one true
        self.on_room: Callable[[], None] | None = None   # process mode: tells the BS anew
        self.notices: deque[_Notice] = deque()
        self._phase = "starting"        # starting | running | busy | stopped | failed
        self.reason = ""
        self._busy = False
        self.enabled = spec.enabled
        self.obj: _Component | None = None
        self.handles: dict[str, SensorHandle | ActuatorHandle] = {}
        self._direct: dict[str, SensorHandle | ActuatorHandle] = {}
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._wake = threading.Event()
        self._abandoned = False
        self._call_started: float | None = None
        self._call_name = ""
        self.started = threading.Event()   # set when running (or failed while starting)
        self.c = Counters(steps=0, late_steps=0, received=0, provided=0, refused=0,
                          puts_ok=0, puts_failed=0, gets_ok=0, gets_failed=0,
                          notices_dropped=0, reserved=0, reserved_refused=0)
        self.last_failure = ""
        period = spec.period if spec.has_period else getattr(cls, "period", None)
        self.period = float(period) if period else None
        dl = spec.options.get("deadline", getattr(cls, "deadline", None))
        # a number (or its text); anything else raises here as float() does
        self.deadline = (float(cast("str | float", dl)) if dl
                         else max(10 * (self.period or 0.1), 1.0))
        self.thread = threading.Thread(target=self._main, name=f"esair:{self.name}", daemon=True)

    @property
    def stopping(self) -> bool:
        return self._stop.is_set()

    # ---- state, seen from other threads
    @property
    def state(self) -> str:
        p = self._phase
        if p == "running" and (self._busy or self._full()):
            return "busy"
        return p

    @property
    def busy(self) -> bool:
        return self._busy

    @busy.setter
    def busy(self, value: bool) -> None:
        changed = bool(value) != self._busy
        self._busy = bool(value)
        if changed:
            self._room_changed()

    @property
    def open(self) -> bool:
        """Takes data now: running and not busy (the mailbox's room is room())."""
        return self._phase == "running" and not self._busy

    @property
    def full(self) -> bool:
        """The mailbox takes no more plain offers now (state "busy")."""
        return self._full()

    def room(self) -> int:
        """How many deliveries into reserved room the BS may have sent, ever: what it
        may send beyond those already taken out (a running total, so a report that is
        late or lost is made good by the next)."""
        return self.taken + RESERVED

    def _full(self) -> bool:
        return self.inbox.qsize() - self._reserved_in >= INBOX

    def _room_changed(self) -> None:
        if self.on_room is not None:
            # the behavior's thread and a transport thread (a put that fills the
            # mailbox) may both report: one at a time, so the last one sent is the truth
            with self._report_lock:
                self._told_taken = self.taken
                self._told_full = self._full()
                try:
                    self.on_room()
                except Exception as exc:  # noqa: BLE001 - the BS falls back to asking
                    log.debug("%s: room not reported: %s", self.name, exc)

    def start(self) -> None:
        self.thread.start()

    def stop(self, timeout: float = 2.0) -> None:
        """Ask the thread to finish (it calls the user's stop()); wait up to ``timeout``."""
        self._stop.set()
        self._wake.set()
        if self.thread.is_alive() and threading.current_thread() is not self.thread:
            self.thread.join(timeout)
        if self.thread.is_alive():
            self._abandoned = True
        with self._lock:
            if self._phase not in ("failed",):
                self._phase = "stopped"

    # ---- the BS's requests (any thread; never run user code here)
    def offer(self, sender: str, data: JSON, wake: bool = True) -> str:
        """Take ``data`` into the mailbox: "delivered", else why not. ``wake=False``:
        the caller calls ``wake()`` itself (after answering, so the behavior's thread
        does not take the GIL from the answer)."""
        if self._stop.is_set():           # being removed: its stop() runs next
            self.c.add("refused")
            return "stopped"
        if self._phase != "running" or self._busy:
            self.c.add("refused")
            return "busy" if self._phase in ("running", "busy", "starting") else self._phase
        if self._full():
            self.c.add("refused")
            return "busy"
        try:
            self.inbox.put_nowait(("deliver", sender, data))
        except queue.Full:
            self.c.add("refused")
            return "busy"
        if self.on_room is not None and self._full():
            self._room_changed()      # the runtime lists it busy without asking it
        if wake:
            self._wake.set()
        return "delivered"

    def deliver_reserved(self, sender: str, data: JSON) -> bool:
        """The BS's delivery into room this host reserved for it (it sends no more than
        room() allows): taken into the mailbox, False (counted) if it finds no room —
        a stopped host, or more than reported (garbage)."""
        with self._lock:
            ok = self._phase not in ("failed", "stopped") and self._reserved_in < RESERVED
            if ok:
                self._reserved_in += 1
        if ok:
            try:
                self.inbox.put_nowait(("reserved", sender, data))
            except queue.Full:          # offers raced past INBOX: not lost silently
                with self._lock:
                    self._reserved_in -= 1
                ok = False
        if not ok:
            self.c.add("reserved_refused")
            return False
        self.c.add("reserved")
        self._wake.set()
        return True

    def wake(self) -> None:
        self._wake.set()

    def request_provide(self, requester: str, reply: Reply) -> str:
        """Queue a provide() call; ``reply((status, data))`` is called from the host thread."""
        if self._phase != "running" or self._busy or self._full() or self._stop.is_set():
            return "busy"
        try:
            self.inbox.put_nowait(("provide", requester, reply))
        except queue.Full:
            return "busy"
        self._wake.set()
        return "queued"

    def provide(self, requester: str, timeout: float) -> Outcome:
        r = _Reply()
        if self.request_provide(requester, r) != "queued":
            return ("busy", self.state)
        if r.wait(timeout):
            return r.value
        return ("busy", f"no answer within {timeout:g} s")

    # a put the sender waits for (esair std put): receive() runs, its outcome answers
    def request_take(self, sender: str, data: JSON, reply: Reply) -> str:
        """Queue ``receive(sender, data)``; ``reply((status, why))`` is called from the
        host thread: ("ok", ""), ("refused", why) when receive() raised Refused, or
        ("failed", why). "busy" when it takes no data now."""
        if self._phase != "running" or self._busy or self._full():
            return "busy"
        try:
            self.inbox.put_nowait(("take", sender, (data, reply)))
        except queue.Full:
            return "busy"
        self._wake.set()
        return "queued"

    def take(self, sender: str, data: JSON, timeout: float) -> Outcome:
        r = _Reply()
        if self.request_take(sender, data, r) != "queued":
            return ("busy", self.state)
        if r.wait(timeout):
            return r.value
        return ("busy", f"no answer within {timeout:g} s")

    def notify_detached(self, resource: str) -> None:
        for h in list(self.handles.values()) + list(self._direct.values()):
            if h.resource == resource:
                h.detached = True
        if len(self.notices) >= NOTICES:
            self.c.add("notices_dropped")
            return
        self.notices.append(resource)
        self._wake.set()

    def notify_attached(self, resource: str) -> None:
        """``resource`` is back (added again): the handles to it work again."""
        for h in list(self.handles.values()) + list(self._direct.values()):
            if h.resource == resource:
                h.detached = False

    def notify_latch(self, state: JSONObject | None, by: str = "") -> None:
        """The robot was STOPPED (``state``) or released by ``by`` (state None): the
        component's robot_stopped() / robot_released() runs on its thread."""
        if len(self.notices) >= NOTICES:
            self.c.add("notices_dropped")
            return
        self.notices.append(("latch", state, by))
        self._wake.set()

    def set_enabled(self, enabled: bool) -> None:
        self.enabled = bool(enabled)

    def check(self, now: float) -> float | None:
        """Watchdog: a user call running past the deadline fails the component. The
        seconds until it needs checking again (a call now running reaches its deadline;
        none running: a call starting now could not overrun sooner), None when never
        (stopped or failed): the watchdog sleeps that long instead of polling."""
        if self._phase in ("failed", "stopped"):
            return None
        started = self._call_started
        if started is None:
            return self.deadline
        left = started + self.deadline - now
        if left < 0:
            self._abandoned = True
            self._fail(f"{self._call_name}() ran over its {self.deadline:g} s deadline")
            return None
        return left + 0.001

    def counters(self) -> JSONObject:
        out: JSONObject = dict(self.c)
        for key, h in self.handles.items():
            out[key] = h.counters()
        return out

    # ---- the component's own calls (its thread)
    def attach_sensor(self, resource: str, keep: int) -> SensorHandle:
        h = SensorHandle(resource, keep, self.port.resource_state)
        self.port.attach_sensor(self.name, resource, h)
        self.handles[f"sensor:{resource}"] = h
        return h

    def register(self, resource: str, level: str) -> str:
        lv = Level.parse(level)
        self.port.register(self.name, resource, lv)
        return lv.name

    def attach_actuator(self, resource: str) -> ActuatorHandle:
        self.port.register(self.name, resource, Level.command)
        h = ActuatorHandle(resource, self._command, self.port.resource_state)
        self.handles[f"actuator:{resource}"] = h
        return h

    def _command(self, resource: str, command: JSON, timeout: float) -> JSON:
        return self.port.command(self.name, resource, command, timeout)

    def direct(self, resource: str) -> SensorHandle | ActuatorHandle:
        if resource not in self.spec.resources:
            raise Refused(f"reaction {self.name!r} does not list {resource!r} in its resources")
        h = self._direct.get(resource)
        if h is None:
            kind = self.port.kind_of(resource)
            if kind == "sensor":
                h = SensorHandle(resource, 64, self.port.resource_state)
                self.port.attach_sensor(self.name, resource, h, direct=True)
            elif kind == "actuator":
                self.port.register(self.name, resource, Level.command)
                h = ActuatorHandle(resource, lambda r, c, t: self.port.command(
                    self.name, r, c, t, direct=True), self.port.resource_state)
            else:
                raise Refused(f"no resource {resource!r}")
            self._direct[resource] = h
            self.handles[f"{kind}:{resource}"] = h
        return h

    def put(self, target: str, data: JSON, timeout: float) -> bool:
        ok, reason = self.port.put(self.name, target, data, timeout)
        self.c.add("puts_ok" if ok else "puts_failed")
        if not ok:
            self.last_failure = f"put to {target!r}: {reason}"
            log.warning("%s: %s", self.name, self.last_failure)
        return ok

    def get(self, target: str, timeout: float) -> JSON:
        ok, value = self.port.get(self.name, target, timeout)
        self.c.add("gets_ok" if ok else "gets_failed")
        if not ok:
            self.last_failure = f"get from {target!r}: {value}"
            log.warning("%s: %s", self.name, self.last_failure)
            return None
        return value

    def state_of(self, name: str) -> str | None:
        return self.port.state_of(name)

    def configure(self, resource: str, key: str, value: JSON) -> JSON:
        return self.port.configure(self.name, resource, key, value)

    def set_reaction(self, name: str, enabled: bool) -> None:
        self.port.set_reaction(self.name, name, enabled)

    def stop_robot(self, reason: str) -> None:
        self.port.stop_robot(self.name, reason)

    # ---- the thread
    def _set_phase(self, phase: str) -> None:
        with self._lock:
            if self._phase in ("failed", "stopped") or self._abandoned:
                return
            self._phase = phase
        self.port.state_changed(self.name, self.generation, phase, "")
        self._room_changed()

    def _fail(self, reason: str) -> None:
        with self._lock:
            if self._phase in ("failed", "stopped"):
                return
            self._phase = "failed"
            self.reason = reason
        self.started.set()
        self._stop.set()
        self._wake.set()
        log.warning("%s failed: %s", self.name, reason)
        self.port.state_changed(self.name, self.generation, "failed", reason)
        self._room_changed()

    def _timed(self, what: str, fn: Callable[[Unpack[_Ts]], _R], *args: Unpack[_Ts]) -> _R:
        self._call_name = what
        self._call_started = time.monotonic()
        try:
            return fn(*args)
        finally:
            self._call_started = None
            if self._abandoned:
                raise _Abandoned()

    def _main(self) -> None:
        try:
            obj = self.obj = build(self.cls, self)
            obj.start()
            if self._stop.is_set():
                return
            runs = (self.period is None and isinstance(obj, Behavior)
                    and type(obj).run is not Behavior.run)
            self.busy = runs               # busy from the moment it is seen running
            self._set_phase("running")
            self.started.set()
            if self.period is None:
                if runs and isinstance(obj, Behavior):
                    try:
                        obj.run()
                    finally:
                        self.busy = False
                while not self._stop.is_set():
                    self._serve(1.0)
            else:
                nxt = time.monotonic()
                while not self._stop.is_set():
                    now = time.monotonic()
                    if now >= nxt:
                        if self.enabled:
                            self._timed("step", obj.step)
                            self.c.add("steps")
                        nxt += self.period
                        if nxt < time.monotonic():
                            self.c.add("late_steps")
                            nxt = time.monotonic() + self.period
                    self._serve(max(0.0, nxt - time.monotonic()))
        except _Abandoned:
            return
        except Exception as exc:  # noqa: BLE001 - the user's code failed: an event, not a crash
            self._fail(f"{type(exc).__name__}: {exc}")
            return
        finally:
            self.started.set()
        if self._phase != "failed" and not self._abandoned and self.obj is not None:
            try:
                self.obj.stop()
            except Exception as exc:  # noqa: BLE001
                log.warning("%s: stop() raised %s: %s", self.name, type(exc).__name__, exc)
            with self._lock:
                if self._phase != "failed":
                    self._phase = "stopped"

    def _receive(self, sender: str, data: JSON) -> None:
        """receive(); a Refused it raises refuses the data (counted, logged: the sender
        did not wait), it does not fail the behavior."""
        try:
            self._timed("receive", self._behavior().receive, sender, data)
        except Refused as exc:
            self.c.add("refused_puts")
            log.warning("%s refused %s's data: %s", self.name, sender, exc)
        self.c.add("received")

    def _take(self, sender: str, data: JSON, reply: Reply) -> None:
        """receive() for a sender that waits for the outcome (request_take)."""
        try:
            self._timed("receive", self._behavior().receive, sender, data)
        except Refused as exc:
            self.c.add("refused_puts")
            self.c.add("received")
            reply(("refused", str(exc)))
            return
        except _Abandoned:
            reply(("failed", "receive() overran its deadline"))
            raise
        except Exception as exc:
            reply(("failed", f"receive() raised {type(exc).__name__}: {exc}"))
            raise
        self.c.add("received")
        reply(("ok", ""))

    def _behavior(self) -> Behavior:
        """The component as a behavior: only behaviors are offered data (bs.py, _target)."""
        return cast(Behavior, self.obj)

    def _serve(self, timeout: float) -> None:
        """Handle notices and mailbox items; wait at most ``timeout`` for the first."""
        obj = self.obj
        assert obj is not None                  # built before the first _serve (_main)
        deadline = time.monotonic() + timeout
        while True:
            while self.notices:
                notice = self.notices.popleft()
                if isinstance(notice, str):
                    self._timed("detached", obj.detached, notice)
                elif notice[1] is not None:
                    st = notice[1]
                    self._timed("robot_stopped", obj.robot_stopped, str(st.get("by", "")),
                                str(st.get("reason", "")))
                else:
                    self._timed("robot_released", obj.robot_released, notice[2])
            try:
                item = self.inbox.get_nowait()
            except queue.Empty:
                left = deadline - time.monotonic()
                if left <= 0 or self._stop.is_set():
                    return
                self._wake.clear()
                if self.inbox.empty() and not self.notices:
                    self._wake.wait(left)
                continue
            if self._told_full and not self._full():
                self._room_changed()      # room again: listed running again
            if item[0] == "reserved":
                with self._lock:
                    self._reserved_in -= 1
                    self.taken += 1
                if self.taken - self._told_taken >= RESERVED // 2:
                    self._room_changed()
                self._receive(item[1], item[2])
            elif item[0] == "deliver":
                self._receive(item[1], item[2])
            elif item[0] == "take":
                self._take(item[1], *item[2])
            elif item[0] == "provide":
                reply = item[2]
                try:
                    value = codec.copy(self._timed("provide", self._behavior().provide, item[1]))
                except _Abandoned:
                    reply(("failed", "provide() overran its deadline"))
                    raise
                except Exception as exc:
                    reply(("failed", f"provide() raised {type(exc).__name__}: {exc}"))
                    raise
                self.c.add("provided")
                reply(("ok", value))
