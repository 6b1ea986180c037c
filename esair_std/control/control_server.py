"""The control endpoint: ``esair/<robot>/ctl/<verb>`` queryables of the runtime.

Zenoh's callback only queues the request (a bounded queue; when full the asker is told
at once); a small pool of worker threads answers from the verb table (transport/wire.py:
the envelope, its errors and the table are those of every endpoint). The verbs that
only read the runtime's own tables (``ping``, ``ls``, ``state``...: :data:`QUICK`) have a
lane of their own: a verb that waits (a put retried until its timeout, a call to a
dead or partitioned agent) may take every worker of the pool, never ``ls``'s. Garbage (not JSON,
not an object, missing or wrong fields, unknown verb) gets an error and changes nothing.

When a component's state changes (the runtime's ``note_change``), a notice goes out on
``esair/<robot>/changed`` (``{"v": n}``, n counting the changes), sent by a thread of its
own (the caller only sets an event; a burst of changes is one notice or a few): a
watcher outside (the HMI) asks ``ls`` when told, instead of asking it all the time.
"""

from __future__ import annotations

import logging
import os
import queue
import threading
import time
from typing import TYPE_CHECKING, Callable, TypeVar, overload

from ..errors import ControlError, Refused
from ..latch import may_stop
from ..level import Level
from ..sample import Sample  # noqa: F401 - documented payload type
from ..transport import keys, wire
from ..transport.codec import JSON, JSONObject
from ..transport.bus import Bus, Request
from ..transport.calls import SampleServer
from ..transport.wire import Verbs

if TYPE_CHECKING:  # pragma: no cover
    from ..bs import BehaviorSupervisor
    from .operator import Operator
    from ..parts import Joins, Mode
    from ..runtime_view import Robot
    from ..rs import ResourceSupervisor
from ..transport.session import check_endpoint, hub_runtime
from ..transport.threads import Threads
from ..counters import Counters

log = logging.getLogger("esair_std.control")
WORKERS = 8
PENDING = 256
_T = TypeVar("_T")
#: verbs answered from the runtime's own tables, never by a call over the network: their
#: own queue and workers (a listing must answer while every other worker waits)
QUICK = frozenset({"ping", "ls", "state", "latch", "kind", "resinfo"})
QUICK_WORKERS = 2


@overload
def _need(body: JSONObject, field: str) -> str: ...
@overload
def _need(body: JSONObject, field: str, kind: type[_T]) -> _T: ...


def _need(body: JSONObject, field: str,
          kind: type[object] | tuple[type[object], ...] = str) -> object:
    if field not in body:
        raise ControlError(f"bad request: missing {field!r}")
    v = body[field]
    if not isinstance(v, kind) or isinstance(v, bool) and kind is not bool:
        names = kind.__name__ if isinstance(kind, type) else "/".join(k.__name__ for k in kind)
        raise ControlError(f"bad request: {field!r} must be a {names}")
    return v


def _timeout(body: JSONObject, default: float = 1.0) -> float:
    t = body.get("timeout", default)
    if isinstance(t, bool) or not isinstance(t, (int, float)) or not 0 <= t <= 3600:
        raise ControlError("bad request: 'timeout' must be a number of seconds (0-3600)")
    return float(t)


def _valid_timeout(body: JSONObject) -> bool:
    try:
        _timeout(body)
    except ControlError:
        return False
    return True


def _latch_body(state: JSONObject | None, by: str = "") -> JSONObject:
    if state is None:          # t: when (a recording orders the states by it)
        return {"stopped": False, "released_by": by, "t": time.time()}
    return {"stopped": True, **state}


class _SampleRequest:
    """A request that came as a sample: the face of transport.bus.Request."""

    __slots__ = ("key", "body", "error", "reply")

    def __init__(self, key: str, body: JSONObject, answer: Callable[[JSONObject], None]):
        self.key, self.body, self.error, self.reply = key, body, "", answer


class ControlServer:
    """The runtime's control endpoint. What it answers from is given, not looked up:
    ``rt`` the robot's own operations (ls, add, remove, inspect...), ``bs`` and ``rs``
    the supervisors, ``mode`` where components live, ``center`` the remote agents'
    (process mode)."""

    def __init__(self, rt: Robot, bs: BehaviorSupervisor, rs: ResourceSupervisor,
                 mode: Mode, center: Joins | None = None):
        self.rt = rt
        self.bs, self.rs, self.mode, self.center = bs, rs, mode, center
        self.endpoint = check_endpoint(rt.endpoint)
        self.bus: Bus | None = None
        self._q: queue.Queue[Request | _SampleRequest | None] = queue.Queue(maxsize=PENDING)
        self._quick: queue.Queue[Request | _SampleRequest | None] = queue.Queue(
            maxsize=PENDING)                                          # QUICK's lane
        self._workers: list[threading.Thread] = []
        self.threads = Threads()     # what may be in a Zenoh call: joined at stop (threads.py)
        self._closing = False
        self._changed = threading.Event()     # a notice is due (changed())
        self._version = 0
        self.c = Counters(requests=0, bad_requests=0, refused_full=0, change_notices=0)
        self.verbs = Verbs(unknown="unknown control verb {verb!r}")
        table: dict[str, wire.Handler] = {
            "ping": self.v_ping, "ls": self.v_ls, "add": self.v_add, "remove": self.v_remove,
            "add-resource": self.v_add_resource, "remove-resource": self.v_remove_resource,
            "put": self.v_put, "get": self.v_get, "configure": self.v_configure,
            "reaction": self.v_reaction, "inspect": self.v_inspect, "state": self.v_state,
            "register": self.v_register, "attach": self.v_attach, "kind": self.v_kind,
            "report": self.v_report, "resstate": self.v_resstate,
            "resinfo": self.v_resstate_get, "hello": self.v_hello,
            "join": self.v_join,
            # the operator's verbs (esair std sample / send): esair_std/control/operator.py
            "sample": self.v_sample, "send": self.v_send,
            # the latched STOP (latch.py): esair std stop / release
            "stop": self.v_stop, "release": self.v_release, "latch": self.v_latch,
        }
        for verb, fn in table.items():
            self.verbs.add(verb, fn)
        self._operator: Operator | None = None     # on first use
        from .observe import install as _observe   # outside principals: the HMI (observe.py)
        self.observe = _observe(self)

    def start(self) -> None:
        hub_runtime()          # before the session: it routes for every agent
        self.bus = Bus(listen=[self.endpoint, *getattr(self.rt, "extra_listen", [])],
                       connect=list(getattr(self.rt, "join", None) or []) or None,
                       options=getattr(self.rt, "session_options", None))
        for _ in range(WORKERS):
            self._workers.append(self.threads.start(self._work, self._q, name="esair:ctl"))
        for _ in range(QUICK_WORKERS):
            self._workers.append(self.threads.start(self._work, self._quick,
                                                    name="esair:ctl-quick"))
        self.bus.serve(keys.ctl(self.rt.robot, "*"), self._enqueue)
        robot = self.rt.robot
        self.puts = SampleServer(self.bus, keys.ctl_put(robot, "*"),
                                 lambda key: keys.bs_answer(robot, keys.name_in(key)),
                                 self._on_put_sample)
        self.token = self.bus.token(keys.alive(self.rt.robot, "runtime", "runtime"))
        self._notice = self.bus.publisher(keys.changed(robot))
        self._latch = self.bus.publisher(keys.latch(robot))
        self.threads.start(self._notify, name="esair:changed")

    def latch_changed(self, state: JSONObject | None, by: str = "") -> None:
        """The latched STOP's state for watchers (the HMI, recorders): ``esair/<robot>/
        latch``."""
        try:
            self._latch(_latch_body(state, by))
        except Exception as exc:  # noqa: BLE001 - the session is closing
            log.debug("latch notice: %s", exc)

    def changed(self, version: int) -> None:
        """A component's state changed (any thread): the notice goes out from
        :meth:`_notify`'s thread."""
        self._version = version
        self._changed.set()

    def _notify(self) -> None:
        while True:
            self._changed.wait()
            if self._closing:
                return
            self._changed.clear()
            try:
                self._notice({"v": self._version})
                self.c.add("change_notices")
            except Exception as exc:  # noqa: BLE001 - the session is closing
                log.debug("change notice: %s", exc)

    def counters(self) -> JSONObject:
        """The control endpoint's own counters (``esair std inspect runtime``): requests,
        garbage refused, requests refused while full, and the put path's samples."""
        self.c["bad_requests"] = self.verbs.c["bad_requests"]
        out: JSONObject = dict(self.c, put_samples=dict(self.puts.c))
        out.update(self.mode.counters())
        return out

    def close(self) -> None:
        """Closes the session (a worker's Zenoh call then fails at once) and tells the
        workers to end; :meth:`join` waits for them."""
        self._closing = True
        self._changed.set()                 # _notify ends
        if self.bus is not None:
            self.bus.close()
        for q, n in ((self._q, WORKERS), (self._quick, QUICK_WORKERS)):
            for _ in range(n):              # a full queue: each worker ends after its item
                try:
                    q.put_nowait(None)
                except queue.Full:
                    pass

    def join(self, timeout: float) -> list[str]:
        """Waits for the workers (after :meth:`close`); the names of those still running."""
        return self.threads.join(timeout)

    def _enqueue(self, req: Request | _SampleRequest) -> None:
        b = req.body
        to = b.get("to") if b is not None else None
        frm = b.get("from", "") if b is not None else None
        if (req.key.endswith("/ctl/put") and b is not None and isinstance(to, str)
                and not b.get("wait")
                and isinstance(frm, str) and _valid_timeout(b)):
            # fast path: the first offer straight from this callback, answered from the
            # offer's answer; a busy target goes on through a worker (retries until the
            # rest of the timeout)
            timeout = _timeout(b)
            deadline = time.monotonic() + timeout

            def first(delivered: bool) -> None:
                if delivered:
                    self.c.add("requests")
                    req.reply({"ok": {"delivered": True, "reason": ""}})
                else:
                    b["timeout"] = max(0.0, deadline - time.monotonic())
                    self._to_worker(req)
            try:
                if self.bs.put_first(frm or "operator", to, b.get("data"),
                                        timeout, first):
                    return
            except Exception as exc:  # noqa: BLE001 - fall back to the ordinary path
                log.debug("put fast path: %s", exc)
        self._to_worker(req)

    def _on_put_sample(self, key: str, body: JSONObject,
                       answer: Callable[[JSONObject], None]) -> None:
        """A component process's put, as a sample on ``ctl/put/<sender>``
        (transport/calls.py): the same handling as the ``ctl/put`` query, the sender
        named by the key (which a remote agent's ACL lets only it use)."""
        body["from"] = keys.name_in(key)
        self._enqueue(_SampleRequest(keys.ctl(self.rt.robot, "put"), body, answer))

    def _to_worker(self, req: Request | _SampleRequest) -> None:
        quick = req.key.rsplit("/", 1)[-1] in QUICK
        try:
            (self._quick if quick else self._q).put_nowait(req)
        except queue.Full:
            self.c.add("refused_full")
            req.reply(wire.error(ControlError("runtime busy: too many requests waiting")))

    def _work(self, q: queue.Queue[Request | _SampleRequest | None]) -> None:
        while True:
            req = q.get()
            if req is None or self._closing:
                return
            req.reply(self.answer(req.key.rsplit("/", 1)[-1], req.body, req.error))

    def answer(self, verb: str, body: JSONObject | None, error: str = "") -> JSONObject:
        self.c.add("requests")
        return self.verbs.answer(verb, body, error)

    # ---- user verbs (the CLI)
    def v_ping(self, b: JSONObject) -> JSONObject:
        # starting: the deployment's components are still being added (resources, then
        # behaviors): a listing now is not the whole robot yet
        return {"robot": self.rt.robot, "mode": self.rt.mode_name, "pid": os.getpid(),
                "starting": not self.rt.started_at, "stopped": self.rt.latched}

    def v_ls(self, b: JSONObject) -> list[JSONObject]:
        if b.get("all"):                 # every row with the same keys, drivers too
            from .listing import components
            return components(self.rt)
        return self.rt.ls()

    def v_add(self, b: JSONObject) -> str:
        uses = b.get("uses") or {}
        if not isinstance(uses, dict):
            raise ControlError("bad request: 'uses' must be an object")
        opts = b.get("options") or {}
        if not isinstance(opts, dict):
            raise ControlError("bad request: 'options' must be an object")
        period = b.get("period")
        if period is not None and (isinstance(period, bool) or not isinstance(period, (int, float))
                                   or period <= 0):
            raise ControlError("bad request: 'period' must be a positive number")
        try:
            uses = {str(k): Level.parse(v) for k, v in uses.items()}
        except ValueError as exc:
            raise ControlError(f"bad request: {exc}") from None
        return self.rt.add(_need(b, "name"), _need(b, "class"), uses=uses, period=period,
                           options=opts)

    def v_remove(self, b: JSONObject) -> None:
        self.rt.remove(_need(b, "name"))

    def v_add_resource(self, b: JSONObject) -> dict[str, str]:
        allow = b.get("allow") or {}
        opts = b.get("options") or {}
        if not isinstance(allow, dict) or not isinstance(opts, dict):
            raise ControlError("bad request: 'allow' and 'options' must be objects")
        try:
            allow = {str(k): Level.parse(v) for k, v in allow.items()}
        except ValueError as exc:
            raise ControlError(f"bad request: {exc}") from None
        return self.rt.add_resource(_need(b, "name"), _need(b, "class"), allow=allow,
                                    options=opts)

    def v_remove_resource(self, b: JSONObject) -> list[str]:
        return self.rt.remove_resource(_need(b, "name"))

    def v_put(self, b: JSONObject) -> JSONObject:
        sender, to = str(b.get("from") or "operator"), _need(b, "to")
        if "/" in to:                             # another robot's behavior: remote/robots.py
            from ..remote import robots
            ok, why = robots.put(self.rt, str(sender), to, b.get("data"), _timeout(b))
        elif b.get("wait"):       # the sender waits for receive(): told if refused
            ok, why = self.bs.put_wait(sender, to, b.get("data"), _timeout(b))
        else:
            ok, why = self.bs.put(sender, to, b.get("data"), _timeout(b))
        return {"delivered": ok, "reason": why}

    def v_get(self, b: JSONObject) -> JSONObject:
        sender, to = str(b.get("from") or "operator"), _need(b, "to")
        if "/" in to:
            from ..remote import robots
            ok, value = robots.get(self.rt, str(sender), to, _timeout(b))
        else:
            ok, value = self.bs.get(sender, to, _timeout(b))
        return {"ok": ok, "data": value if ok else None, "reason": "" if ok else value}

    def v_configure(self, b: JSONObject) -> JSON:
        who = b.get("who")
        return self.rs.configure(who if isinstance(who, str) else None,
                                    _need(b, "resource"), _need(b, "key"), b.get("value"))

    def v_reaction(self, b: JSONObject) -> None:
        self.bs.set_reaction(_need(b, "name"), _need(b, "enabled", bool))

    def v_inspect(self, b: JSONObject) -> JSONObject:
        return self.rt.inspect(_need(b, "name"))

    def v_state(self, b: JSONObject) -> str | None:
        return self.rt.state(_need(b, "name"))

    def _op(self) -> Operator:
        if self._operator is None:
            from .operator import Operator
            self._operator = Operator(self.rt)
        return self._operator

    def v_sample(self, b: JSONObject) -> JSONObject:
        s = self._op().sample(_need(b, "name"), _timeout(b, 2.0))
        return {"resource": s.source, "seq": s.seq, "t": s.t, "value": s.value}

    def v_send(self, b: JSONObject) -> JSON:
        return self._op().send(_need(b, "name"), b.get("value"), _timeout(b))

    def v_stop(self, b: JSONObject) -> JSONObject:
        who = b.get("who") or "operator"
        reason = b.get("reason") or ""
        if not isinstance(who, str) or not isinstance(reason, str):
            raise ControlError("bad request: 'who' and 'reason' must be text")
        may_stop(self.bs.records, who)
        return self.rt.stop_robot(reason, by=who)

    def v_release(self, b: JSONObject) -> JSONObject:
        who = b.get("who") or "operator"
        if not isinstance(who, str):
            raise ControlError("bad request: 'who' must be text")
        if who in self.bs.records:
            raise Refused(f"{self.bs.records[who].spec.kind} {who!r} may not release the "
                          f"STOP: only an operator may (esair std release)")
        return self.rt.release_robot(by=who)

    def v_latch(self, b: JSONObject) -> JSONObject:
        return _latch_body(self.rt.latched)

    # ---- agent verbs (component processes)
    def v_register(self, b: JSONObject) -> int:
        try:
            level = Level.parse(_need(b, "level"))
        except ValueError as exc:
            raise ControlError(f"bad request: {exc}") from None
        return self.mode.port.register(_need(b, "who"), _need(b, "resource"), level)

    def v_attach(self, b: JSONObject) -> None:
        self.mode.port.attach_sensor(_need(b, "who"), _need(b, "resource"), None,
                                        direct=bool(b.get("direct")))

    def v_kind(self, b: JSONObject) -> str | None:
        return self.rs.kind_of(_need(b, "resource"))

    def v_report(self, b: JSONObject) -> None:
        self.mode.reported(_need(b, "name"), _need(b, "generation", int),
                              _need(b, "phase"), str(b.get("reason", "")))

    def v_resstate(self, b: JSONObject) -> None:
        self.rs.set_state(_need(b, "resource"), _need(b, "state"), str(b.get("reason", "")))

    def v_resstate_get(self, b: JSONObject) -> list[str]:
        """[state, reason] of a resource ("gone" when there is none)."""
        state, why = self.rs.states.get(_need(b, "resource"), ("gone", "no such resource"))
        return [state, why]

    def v_hello(self, b: JSONObject) -> None:
        self.mode.hello(b)

    def v_join(self, b: JSONObject) -> JSONObject:
        if self.rt.mode_name != "process":
            raise ControlError("this runtime runs in thread mode: it takes no remote agents")
        if self.center is None:
            raise ControlError("this runtime takes no remote agents")
        return self.center.join(b)
