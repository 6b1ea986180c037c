"""Runtime: one robot's deployment running in thread or process mode.

    with Runtime("lab.yaml", mode="process") as rt:
        rt.put("logger", {"hello": 1})
        print(rt.ls())

The mode decides where components live (threads of this process, or one OS process per
component joined by Zenoh), never what they do. The runtime owns the four resident
components (BS, RS, SC, AC) and, when asked (``control=True``, always in process mode),
serves the control endpoint that ``esair std ...`` and agent processes talk to.
"""

from __future__ import annotations

import logging
import os
import socket
import threading
import time
import weakref
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping

from . import spec as specmod
from .bs import BehaviorSupervisor
from .connections import ActuatorConnection, SensorConnection
from .errors import ComponentError, ControlError, Refused, StdError
from .heap import settle
from .latch import Latch, refusal
from .level import Level
from .policy import uses_problem
from .rs import ResourceSupervisor
from .spec import Spec
from .transport.codec import JSON, JSONObject

if TYPE_CHECKING:  # pragma: no cover
    from .deploy.model import Deployment
    from .lean.plain import PlainDeployment
    from .control.control_server import ControlServer
    from .parts import ComponentHost, Mode, ResourceHost
    from .supervisor import Record
    from .remote.center import Center

log = logging.getLogger("esair_std.runtime")
MODES = ("thread", "process")
STOP_JOIN = 5.0       # stop(): the longest wait for the runtime's threads to end
WATCH_IDLE = 1.0      # the watchdog's longest sleep (a component added meanwhile wakes it)
WAIT_RECHECK = 0.1    # wait_state: how often a state no event announces (busy) is looked at


def _load(deployment: str | Path | dict[str, object] | Deployment | PlainDeployment,
          ) -> Deployment | PlainDeployment:
    """A Deployment from a path, a dict or an already loaded Deployment (or one checked
    elsewhere and plain, lean/plain.py: ``esair std run``'s)."""
    if isinstance(deployment, (str, Path, dict)):
        from .deploy import load_deployment
        return load_deployment(deployment)
    return deployment


class Runtime:
    def __init__(self, deployment: str | Path | dict[str, object] | Deployment | PlainDeployment,
                 mode: str | None = None,
                 endpoint: str | None = None, control: bool | None = None,
                 join: list[str] | None = None, settle_heap: bool = False,
                 stopped: bool | str = False):
        self.deployment = _load(deployment)
        # the process is the runtime's own (esair std run): its start-up heap is frozen
        # once the resources are open, before any behavior runs (heap.py)
        self.settle_heap = settle_heap
        self.join = list(join or [])     # other robots' control endpoints (remote/robots.py)
        self.robot = self.deployment.robot
        self.mode_name = mode or getattr(self.deployment, "mode", None) or "thread"
        if self.mode_name not in MODES:
            raise ControlError(f"unknown mode {self.mode_name!r} (expected thread or process)")
        self.endpoint = endpoint or self.deployment.endpoint
        self.control = (self.mode_name == "process") if control is None else bool(control)
        self.base_dir = str(getattr(self.deployment, "base_dir", None) or os.getcwd())
        self.hostname = socket.gethostname()
        self.sc = SensorConnection()
        self.rs = ResourceSupervisor(self._start_resource, self.sc, self._detached,
                                     self._attached, self._uses_of)
        self.ac = ActuatorConnection(self.rs)
        self.bs = BehaviorSupervisor(self._start_component, self.rs, self._forget)
        self.server: ControlServer | None = None
        self.session_options: Mapping[str, object] | None = None
        self.extra_listen: list[str] = []
        self.local_endpoint: str | None = None     # where local children connect
        self.child_session: dict[str, str] | None = None   # their login (remote/center.py)
        self.center: Center | None = None          # remote agents (process mode)
        self._stop = threading.Event()
        self._kick = threading.Event()      # wakes the watchdog: a component started
        self._changed = threading.Condition()   # a state changed (wait_state waits on it)
        self._version = 0
        self.bs.on_change = self.rs.on_change = self.note_change
        # the latched STOP (latch.py); ``stopped``: start latched (True, or the reason)
        self.latch = Latch()
        self._latching = threading.Lock()
        if stopped:
            state, _ = self.latch.stop("operator", stopped if isinstance(stopped, str)
                                       else "started stopped (--stopped)")
            self.rs.halted = refusal(state)
        self._watch: threading.Thread | None = None
        self.started_at = 0.0
        if self.mode_name == "thread":
            from .modes.thread import ThreadMode
            self.mode: Mode = ThreadMode(self)
        else:
            from .modes.process import ProcessMode
            self.mode = ProcessMode(self)

    # ---- life cycle
    def start(self) -> "Runtime":
        try:
            if self.control:
                from .remote.center import Center, session
                self.session_options, self.extra_listen, self.local_endpoint = session(self)
                self.center = Center(self)
                from .control.control_server import ControlServer
                self.server = ControlServer(self, self.bs, self.rs, self.mode, self.center)
                self.server.start()
            from .lean.plain import PlainDeployment
            if isinstance(self.deployment, PlainDeployment):   # checked where it was made
                res, beh, rea = self.deployment.split()
            else:
                from .deploy import load_classes
                load_classes(self.deployment)     # every class, errors at file:line:col
                res, beh, rea = specmod.specs_of(self.deployment)
            self.mode.open()
            for s in res:
                self.rs.add(s)              # each opened (or failed) on return
            if self.settle_heap:
                settle()
            for s in rea + beh:
                self.bs.add(s)              # each started on return
            self.rs.start()
            self.bs.start()
            self._watch = threading.Thread(target=self._watchdog, name="esair:watch",
                                           daemon=True)
            self._watch.start()
        except BaseException:
            self.stop()
            raise
        _stop_at_exit(self)
        self.started_at = time.time()
        return self

    def stop(self) -> None:
        """Stops every component and resource, closes the session, and returns once the
        runtime's threads that may call into Zenoh have ended (transport/threads.py: one
        left inside a Zenoh call when the interpreter finalizes aborts the program)."""
        self._stop.set()
        self._kick.set()
        self.bs.stop_all()
        self.rs.stop_all()
        if self._watch is not None and self._watch.is_alive():
            self._watch.join(1.0)
        server, self.server = self.server, None
        if server is not None:
            server.close()
        self.mode.close()
        deadline = time.monotonic() + STOP_JOIN
        left = server.join(STOP_JOIN) if server is not None else []
        threads = getattr(self.mode, "threads", None)
        if threads is not None:
            left += threads.join(max(0.0, deadline - time.monotonic()))
        if left:
            log.warning("stop: threads still running after %g s: %s", STOP_JOIN,
                        ", ".join(left))

    def __enter__(self) -> "Runtime":
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def _watchdog(self) -> None:
        """Sleeps until a host's deadline can next be reached (ComponentHost.check), not
        a fixed tick: idle components cost no wake-ups."""
        wait = 0.0
        while True:
            self._kick.wait(wait)
            self._kick.clear()
            if self._stop.is_set():
                return
            try:
                nxt = self.mode.watch(time.monotonic())
            except Exception as exc:  # noqa: BLE001 - keep watching
                log.error("watchdog: %s", exc)
                nxt = None
            wait = WATCH_IDLE if nxt is None else min(max(nxt, 0.001), WATCH_IDLE)

    def _start_component(self, spec: Spec, generation: int) -> ComponentHost:
        host = self.mode.start_component(spec, generation)
        self._kick.set()                    # its deadline joins the watchdog's
        return host

    def _start_resource(self, spec: Spec, generation: int) -> ResourceHost:
        return self.mode.start_resource(spec, generation)

    def _forget(self, name: str) -> None:
        forget = getattr(self.mode, "forget", None)
        if forget is not None:
            forget(name)

    def _detached(self, behavior: str, resource: str) -> None:
        self.bs.notify_detached(behavior, resource)

    def _attached(self, behavior: str, resource: str) -> None:
        self.bs.notify_attached(behavior, resource)

    def _uses_of(self, who: str) -> dict[str, str] | None:
        """What ``who`` may register for: its ``uses`` (None: a reaction, fixed in the
        deployment; {}: not deployed, nothing)."""
        rec = self.bs.records.get(who)
        if rec is None:
            return {}
        return None if rec.spec.kind == "reaction" else rec.spec.uses

    # ---- the latched STOP (docs/std.md, "The latched stop")
    def stop_robot(self, reason: str = "", by: str = "operator") -> JSONObject:
        """STOP: every motion stopped at once, every queued actuator command dropped
        (its sender told why), every new one refused until :meth:`release_robot`.
        Sensors and behaviors go on. Returns the state (``by``, ``t``, ``at``,
        ``reason``); a STOP while stopped stops the devices again and keeps the
        first one's who and when."""
        with self._latching:        # a STOP and a release never interleave (two pages)
            state, _new = self.latch.stop(by, reason)
            self.rs.halt(refusal(state))
            self.bs.notify_latch(state)
            self._latch_changed(state)
        log.warning("STOPPED by %s%s", by, f": {reason}" if reason else "")
        return state

    def release_robot(self, by: str = "operator") -> JSONObject:
        """Release the STOP (the operator's deliberate act): commands are taken again;
        nothing starts by itself. ControlError when the robot is not stopped."""
        with self._latching:
            was = self.latch.release(by)
            self.rs.unhalt()
            self.bs.notify_latch(None, by)
            self._latch_changed(None, by)
        log.warning("released by %s (stopped by %s at %s)", by, was["by"], was["at"])
        return was

    @property
    def latched(self) -> JSONObject | None:
        """The STOP in effect (``by``, ``t``, ``at``, ``reason``), or None."""
        return self.latch.get()

    def _latch_changed(self, state: JSONObject | None, by: str = "") -> None:
        self.note_change()
        server = self.server
        if server is not None:
            server.latch_changed(state, by)

    # ---- control (the CLI's verbs; also the Python API)
    def state(self, name: str) -> str | None:
        s = self.bs.state_of(name)
        if s is None:
            s = self.rs.state_of(name)
            if s is None and name in self.rs.entries:
                s = self.rs.entries[name][1].state
        return s

    def ls(self) -> list[JSONObject]:
        rows: list[JSONObject] = []
        for name, rec in list(self.bs.records.items()):
            rows.append(dict(name=name, kind=rec.spec.kind, state=rec.host.state,
                             pid=getattr(rec.host, "pid", os.getpid()),
                             host=getattr(rec.host, "hostname", self.hostname),
                             restarts=rec.restarts, reason=_reason(rec),
                             detached=self.rs.detached_of(name),
                             **{"class": rec.spec.class_path}))
        for entry, (spec, host) in list(self.rs.entries.items()):
            for res, (e, kind) in list(self.rs.resources.items()):
                if e != entry:
                    continue
                st, why = self.rs.states.get(res, ("?", ""))
                rows.append(dict(name=res, kind=kind, state=st,
                                 pid=getattr(host, "pid", os.getpid()),
                                 host=getattr(host, "hostname", self.hostname),
                                 restarts=self.rs.restarts_of(entry),
                                 reason=why, attached=self.sc.attached_to(res),
                                 **{"class": spec.class_path}))
        return rows

    def add(self, name: str, class_path: str, uses: Mapping[str, Level | str] | None = None,
            period: float | None = None, options: JSONObject | None = None,
            restart: tuple[int, float] = (0, 0.0), kind: str = "behavior",
            resources: tuple[str, ...] = (), enabled: bool = True) -> str:
        _check_name(name)
        s = Spec(kind, name, class_path, dict(options or {}), self.base_dir,
                 period=period, has_period=period is not None,
                 uses={k: Level.parse(v).name for k, v in (uses or {}).items()},
                 restart_max=int(restart[0]), restart_within=float(restart[1]),
                 resources=tuple(resources), enabled=enabled)
        why = uses_problem(name, s.uses, {e: spec.allow for e, (spec, _h)
                                          in list(self.rs.entries.items())})
        if why is not None:        # as the deployment file's check refuses it
            raise Refused(why)
        rec = self.bs.request(self.bs.add, s)
        if rec.host.state == "failed":   # start() raised: nothing is left of it
            reason = _reason(rec)
            self.bs.request(self.bs.remove, name)
            raise ComponentError(f"{kind} {name!r} did not start: {reason}")
        return rec.host.state

    def remove(self, name: str) -> None:
        self.bs.request(self.bs.remove, name)

    def add_resource(self, name: str, class_path: str,
                     allow: Mapping[str, Level | str] | None = None,
                     options: JSONObject | None = None,
                     restart: tuple[int, float] = (0, 0.0)) -> dict[str, str]:
        _check_name(name)
        if name in self.bs.records:
            raise ControlError(f"a {self.bs.records[name].spec.kind} named {name!r} is"
                               " already deployed")
        s = Spec("resource", name, class_path, dict(options or {}), self.base_dir,
                 allow={k: Level.parse(v).name for k, v in (allow or {}).items()},
                 restart_max=int(restart[0]), restart_within=float(restart[1]))
        return self.rs.request(self.rs.add, s)

    def remove_resource(self, name: str) -> list[str]:
        return self.rs.request(self.rs.remove, name)

    def put(self, name: str, data: object, timeout: float = 1.0,
            sender: str = "operator") -> None:
        ok, why = self.bs.put(sender, name, data, timeout)
        if not ok:
            raise ControlError(f"put to {name!r} failed: {why}")

    def get(self, name: str, timeout: float = 1.0, requester: str = "operator") -> Any:
        ok, value = self.bs.get(requester, name, timeout)
        if not ok:
            raise ControlError(f"get from {name!r} failed: {value}")
        return value

    def configure(self, resource: str, key: str, value: JSON) -> Any:
        return self.rs.configure(None, resource, key, value)

    def reaction(self, name: str, enabled: bool) -> None:
        self.bs.set_reaction(name, enabled)

    def inspect(self, name: str) -> JSONObject:
        rec = self.bs.records.get(name)
        if rec is not None:
            return dict(name=name, kind=rec.spec.kind, state=rec.host.state,
                        restarts=rec.restarts, reason=_reason(rec),
                        counters=rec.host.counters())
        if name in self.rs.resources or name in self.rs.entries:
            entry = self.rs.resources[name][0] if name in self.rs.resources else name
            host = self.rs.entries[entry][1]
            counters = host.counters()
            st = self.rs.states.get(name, (host.state, ""))
            return dict(name=name, kind=self.rs.kind_of(name) or "resource", state=st[0],
                        reason=st[1], attached=self.sc.attached_to(name),
                        grants={w: str(lv) for (w, r), lv in self.rs.grants.items()
                                if r == name},
                        refused=self.rs.refused_on.get(name, 0),
                        counters=counters.get(name, counters))
        if name == "runtime" and self.server is not None:
            return dict(name="runtime", kind="runtime", state="running",
                        counters=self.server.counters())
        from .bs import _hint
        names = [*self.bs.records, *self.rs.entries, *self.rs.resources]
        raise ControlError(f"no component {name!r}{_hint(name, names)}")

    def note_change(self) -> None:
        """A component's state changed (supervisors, hosts, agents' reports)."""
        with self._changed:
            self._version += 1
            self._changed.notify_all()
        server = self.server
        if server is not None:
            server.changed(self._version)    # the notice for watchers outside (the HMI)

    def wait_state(self, name: str, states: str | tuple[str, ...], timeout: float = 10.0) -> str:
        """Wait until ``name`` is in one of ``states``; its state (for tests, scripts).
        Woken by every change the runtime is told of; ``busy`` (a behavior's own flag,
        not an event) is looked at again every WAIT_RECHECK seconds."""
        want = (states,) if isinstance(states, str) else tuple(states)
        deadline = time.monotonic() + timeout
        while True:
            seen = self._version
            s = self.state(name)
            if s in want:
                return s
            left = deadline - time.monotonic()
            if left <= 0:
                raise ControlError(f"{name!r} is {s}, not {'/'.join(want)}, after {timeout:g} s")
            def moved(v: int = seen) -> bool:
                return self._version != v
            with self._changed:
                self._changed.wait_for(moved, min(left, WAIT_RECHECK))

    def summary(self) -> list[JSONObject]:
        """Per component: state, samples delivered/overwritten, puts ok/failed, restarts."""
        rows: list[JSONObject] = []
        for row in self.ls():
            try:
                info = self.inspect(str(row["name"]))
            except StdError:
                continue
            c = info.get("counters", {})
            if not isinstance(c, dict):
                c = {}
            recv = sum(_count(v, "received") for v in c.values() if isinstance(v, dict))
            over = sum(_count(v, "overwritten") for v in c.values() if isinstance(v, dict))
            rows.append(dict(name=row["name"], kind=row["kind"], state=row["state"],
                             samples=recv if row["kind"] in ("behavior", "reaction")
                             else c.get("reported", 0),
                             overwritten=over, commands=c.get("commands", 0),
                             puts_ok=c.get("puts_ok", 0),
                             puts_failed=c.get("puts_failed", 0),
                             restarts=row.get("restarts", 0)))
        return rows


def _stop_at_exit(rt: Runtime) -> None:
    """A program that leaves without ``rt.stop()``: the runtime is stopped at its exit,
    before the interpreter waits for its non-daemon threads (zenoh-python's liveliness
    thread lives as long as the session: the program hung forever) and before it
    finalizes under threads still inside Zenoh (SIGABRT, transport/threads.py). Holds
    the runtime weakly: a runtime dropped earlier is not kept alive by this."""
    ref = weakref.ref(rt)

    def at_exit() -> None:
        r = ref()
        if r is not None and not r._stop.is_set():
            r.stop()

    try:
        # runs before the non-daemon threads' join (concurrent.futures uses it too)
        threading._register_atexit(at_exit)  # type: ignore[attr-defined]
    except RuntimeError:                      # the interpreter is already shutting down
        pass


def _count(counters: JSONObject, key: str) -> int | float:
    """A number among a handle's counters (0 when it has none of that name)."""
    v = counters.get(key, 0)
    return v if isinstance(v, (int, float)) else 0


def _reason(rec: Record[ComponentHost]) -> str:
    if rec.host.state != "failed":
        return ""
    return getattr(rec.host, "reason", "") or rec.reason


def _check_name(name: str) -> None:
    import re
    if not re.fullmatch(r"[a-z][a-z0-9_]*", name or ""):
        raise ControlError(f"name {name!r} is not of the form [a-z][a-z0-9_]*")
