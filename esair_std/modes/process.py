"""Process mode: each behavior, reaction and resource entry its own OS process, started
as ``python -m esair_std.hosts.agent_process`` and joined to the runtime over Zenoh; the four
resident components (BS, RS, SC, AC) stay in the runtime's process.

The runtime sees each child through a proxy with the same methods as the thread-mode
hosts (offer, provide, state, stop, configure, grant...), answered by the agent over the
``bs/<name>`` and ``rs/<entry>`` queryables. A child is failed when its liveliness token
goes (SIGKILL: milliseconds), when its process exits, or when it says so itself.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import subprocess
import sys
import threading
import time
from typing import TYPE_CHECKING, Any, Callable, Iterator

from esair_min import sigs

from ..errors import ComponentError, ResourceLost, StdError, TransportError
from ..parts import NO_ANSWER
from ..spec import Spec
from ..transport import codec, keys, session, wire
from ..transport.codec import JSON, JSONObject
from ..transport.calls import SampleCaller
from ..transport.security_config import link_inserts
from ..transport.threads import Threads
from ..hosts.agent_process import MARGIN
from .forkserver import ForkServer, Forked
from .thread import LocalPort

if TYPE_CHECKING:  # pragma: no cover
    from ..transport.bus import Bus
    from ..runtime_view import RuntimeView

log = logging.getLogger("esair_std.process")
START_TIMEOUT = 20.0
# a resource's process says hello once its device is open: an emulated robot alone may
# take up to its own start timeout (drivers/minlink/emulated.py, 30 s) on a loaded machine
RESOURCE_START_TIMEOUT = 45.0
RESERVED_BYTES = 8192    # a put this small may go into a component's reserved room: at
                         # most host.RESERVED of them under way fit any link's queue


AGENT_MODULE = "esair_std.hosts.agent_process"


def agent_command(endpoint: str, robot: str, spec: Spec, generation: int) -> list[str]:
    # children listen on the loopback only: nobody from another computer reaches them
    # past the control endpoint's security (remote agents go through the runtime)
    options = {"listen/endpoints": ["tcp/127.0.0.1:0"], **link_inserts()}
    if spec.kind != "resource":
        # a behavior or reaction dials only the runtime: the resource agents dial it when
        # the runtime's gossip names it (sensor data and commands still flow directly).
        # Without this every agent dialled every other (a full mesh): with 10 behaviors
        # each had 11 links, 1.2-1.4 MB more RSS per process, for no traffic.
        options["scouting/gossip/autoconnect"] = {"peer": []}
        # nor does its session wait, opening, for peers it will not dial: with the wait,
        # 1 open in ~50 took Zenoh's whole scouting delay (500 ms: a restart or an add
        # 0.57 s instead of 0.08 s); without it open takes ~1 ms, and the agent asks
        # again until the runtime answers its hello (agent.py)
        options["open/return_conditions/connect_scouted"] = False
    # -P: the folder it starts in is not put on sys.path (a numpy.py there shadows
    # nothing); the deployment's own modules are found by the class importer (classes.py)
    return [sys.executable, "-P", "-m", AGENT_MODULE, "--connect", endpoint,
            "--robot", robot, "--generation", str(generation),
            "--spec", json.dumps(spec.to_json()), "--session-options", json.dumps(options)]


def _how_it_ended(status: int | None) -> str:
    if status is not None and status < 0:
        return f"was killed by signal {-status}"
    return f"exited with status {status}" if status is not None else "exited"


class _Child:
    """What component and resource proxies share: the process, hello, stop."""

    def __init__(self, mode: "ProcessMode", spec: Spec, generation: int):
        self.mode = mode
        self.bus = mode.bus
        self.robot = mode.rt.robot
        self.spec = spec
        self.name = spec.name
        self.generation = generation
        self.phase = "starting"
        self.reason = ""
        self.pid: int | None = None
        self.hostname = ""
        self.info: JSONObject = {}               # its hello
        self.hello = threading.Event()
        self.ended = threading.Event()           # its process exited (not yet reaped)
        self.changed = threading.Event()         # hello, a phase reported, or ended
        self.proc: subprocess.Popen[bytes] | Forked | None = None
        self.remote = spec.name in mode.remote   # a remote agent (esair_std.remote): not ours
        self.quiet = False                       # remote: do not tell it to stop
        self.rejoining = False

    def spawn(self) -> None:
        if self.remote:
            return                               # already running on its own computer
        env = self.mode.child_env()
        cmd = agent_command(self.mode.rt.local_endpoint or self.mode.rt.endpoint, self.robot,
                            self.spec, self.generation)
        # forked by the zygote when it can (modes/forkserver.py), else a new interpreter;
        # either way in the user's folder: relative paths as in thread mode
        args = cmd[cmd.index(AGENT_MODULE) + 1:]
        forked = self.mode.forks.spawn(args, env, cmd) if self.mode.forks else None
        proc = forked or subprocess.Popen(cmd, stdin=subprocess.PIPE, env=env)
        self.proc, self.pid = proc, proc.pid
        self.mode.threads.start(self._watch_exit, proc.pid, name=f"esair:exit:{self.name}")

    def _watch_exit(self, pid: int) -> None:
        """Blocks until the process exits (waitid with WNOWAIT: Popen still reaps it),
        then tells: an event, never a periodic poll."""
        with contextlib.suppress(ChildProcessError):     # already reaped by Popen
            os.waitid(os.P_PID, pid, os.WEXITED | os.WNOWAIT)
        self.ended.set()
        self.changed.set()
        self.on_exit()

    def on_exit(self) -> None:
        """Its process exited (from its exit watcher's thread)."""

    def note(self) -> None:
        """Something a waiter of ``changed`` looks at changed."""
        self.changed.set()

    def wait_hello(self) -> None:
        limit = RESOURCE_START_TIMEOUT if self.spec.kind != "behavior" else START_TIMEOUT
        deadline = time.monotonic() + limit
        while True:
            self.changed.clear()
            if self.hello.is_set():
                break
            if self.ended.is_set():
                raise ComponentError(f"{self.spec.kind} {self.name!r}: its process "
                                     f"{_how_it_ended(self.exited())} before it started")
            left = deadline - time.monotonic()
            if left <= 0:
                self.kill()
                raise ComponentError(f"{self.spec.kind} {self.name!r} did not start within"
                                     f" {limit:g} s")
            sigs.wait(self.changed, left)       # a signal on any thread interrupts it
        if self.info.get("error"):
            self.kill()
            raise ComponentError(str(self.info["error"]))

    def ask(self, key: str, body: JSONObject, timeout: float) -> JSON:
        try:
            r: JSON = self.bus.request(key, body, timeout)
        except StdError:
            return None
        return r

    def exited(self) -> int | None:
        """Its exit status once it ended (reaped here; negative: the signal's number)."""
        if self.proc is None:
            return None
        if self.ended.is_set():
            with contextlib.suppress(subprocess.TimeoutExpired):
                return self.proc.wait(1.0)
        return self.proc.poll()

    def kill(self) -> None:
        if self.proc is None:
            return
        try:
            if self.proc.stdin:
                self.proc.stdin.close()
        except OSError:
            pass
        if self.proc.poll() is None:
            self.proc.kill()
        try:
            self.proc.wait(2.0)
        except subprocess.TimeoutExpired:
            log.error("%s (pid %s) did not die", self.name, self.pid)

    def stop_process(self, key: str, timeout: float) -> None:
        if self.remote:
            if not self.quiet:
                self.ask(key, {"op": "stop", "timeout": timeout}, min(timeout, 0.5))
            return
        if self.proc is not None and self.proc.poll() is None:
            self.ask(key, {"op": "stop", "timeout": timeout}, min(timeout, 1.0))
            try:
                self.proc.wait(timeout + 0.5)
            except subprocess.TimeoutExpired:
                pass
        self.kill()


class ProcessComponent(_Child):
    """The runtime's view of a behavior or reaction living in an agent process.

    The BS knows a local component's state without asking it each time: the component
    reports (on ``bs/<name>/credit``) whether it takes data and how much mailbox room it
    has reserved for the BS (a running total, ComponentHost.room()). While both say yes,
    a put is delivered into that room with one sample (``bs/<name>/deliver``) and the
    sender is told at once; else the BS asks, as offer() does, and retries. Only for
    local children and small data: the room is then sure to be there when the sample
    arrives (loopback, at most RESERVED of them under way), so "delivered" is never a
    guess. A remote agent, across a link that may be cut, is always asked."""

    credit_known = False     # a report came: the state below is known without asking
    credit_open = False      # the last report: the component takes data
    credit_full = False      # the last report: its mailbox is full (listed busy)
    credit_room = 0          # deliveries into reserved room it allows, ever
    credit_sent = 0          # deliveries into reserved room sent, ever

    @property
    def key(self) -> str:
        return keys.bs(self.robot, self.name)

    @property
    def state(self) -> str:
        """Known here, never asked of the agent: its phase (reported), busy while its
        last report of its room says it takes no data or its mailbox is full (a round
        trip per component would make ``ls`` wait on every starved or frozen agent)."""
        if self.remote or self.phase != "running" or not self.credit_known:
            return self.phase        # a remote agent reports its phases
        return "busy" if not self.credit_open or self.credit_full else "running"

    def credit(self, open_: bool, room: int, full: bool = False) -> None:
        with self.mode.credit_lock:
            self.credit_known = True
            self.credit_open = open_
            self.credit_full = full
            self.credit_room = max(self.credit_room, room)

    def deliver_reserved(self, sender: str, data: JSON,
                         told: Callable[[], None] | None = None) -> bool:
        """Deliver ``data`` into the room the component reserved: True if sent (the
        sender may be told "delivered"), False to ask it instead. ``told``: called once
        the room is taken, before the delivery's sample goes (the sender's answer is on
        its way a publish sooner); a sample that then cannot go is counted."""
        if self.remote or self.phase != "running" or not self.credit_open:
            return False
        try:
            body = codec.encode({"from": sender, "data": data})
        except StdError:
            return False
        if len(body) > RESERVED_BYTES:
            return False
        with self.mode.credit_lock:
            if not self.credit_open or self.credit_sent >= self.credit_room:
                return False
            self.credit_sent += 1
        if told is not None:
            told()
            try:
                self.mode.deliver(self.name, body)
            except Exception as exc:  # noqa: BLE001 - the session or publisher is gone
                self.mode.credits["unsent"] += 1
                log.warning("delivery to %s not sent: %s", self.name, exc)
            return True
        try:
            self.mode.deliver(self.name, body)
        except Exception as exc:  # noqa: BLE001 - not sent: ask instead
            log.debug("delivery to %s not sent: %s", self.name, exc)
            with self.mode.credit_lock:
                self.credit_sent -= 1
            return False
        return True

    def offer(self, sender: str, data: JSON) -> str:
        if self.phase in ("failed", "stopped"):
            return self.phase
        if self.deliver_reserved(sender, data):
            return "delivered"
        r = self.ask(self.key, {"op": "offer", "from": sender, "data": data}, 1.0)
        return r.get("ok", "gone") if isinstance(r, dict) else "gone"

    def offer_async(self, sender: str, data: JSON, done: Callable[[str], None],
                    timeout: float) -> bool:
        """``offer`` without waiting: ``done(result)`` on a Zenoh thread, or "gone"
        after ``timeout`` (transport/calls.py). False: not sent, use ``offer``."""
        if self.phase in ("failed", "stopped"):
            done(self.phase)
            return True
        if self.deliver_reserved(sender, data, lambda: done("delivered")):
            return True

        def answer(a: JSON) -> None:
            r = a.get("r") if isinstance(a, dict) else None
            done(r if isinstance(r, str) else "gone")
        try:
            return self.mode.offers.call(keys.bs_offer(self.robot, self.name), self.name,
                                         {"from": sender, "data": data}, min(timeout, 1.0),
                                         answer)
        except StdError:
            return False

    def provide(self, requester: str, timeout: float) -> tuple[str, JSON]:
        if self.phase in ("failed", "stopped"):
            return ("busy", self.phase)
        r = self.ask(self.key, {"op": "provide", "from": requester, "timeout": timeout},
                     timeout)
        if isinstance(r, dict) and isinstance(r.get("ok"), list) and len(r["ok"]) == 2:
            return tuple(r["ok"])
        return ("busy", NO_ANSWER)

    def take(self, sender: str, data: JSON, timeout: float) -> tuple[str, JSON]:
        """A put the sender waits for: receive() runs in the agent, its outcome answers
        (ComponentHost.take)."""
        if self.phase in ("failed", "stopped"):
            return ("busy", self.phase)
        r = self.ask(self.key, {"op": "take", "from": sender, "data": data,
                                "timeout": timeout}, timeout + 0.05)
        if isinstance(r, dict) and isinstance(r.get("ok"), list) and len(r["ok"]) == 2:
            return tuple(r["ok"])
        return ("busy", NO_ANSWER)

    def notify_detached(self, resource: str) -> None:
        self.ask(self.key, {"op": "detached", "resource": resource}, 1.0)

    def notify_attached(self, resource: str) -> None:
        self.ask(self.key, {"op": "attached", "resource": resource}, 1.0)

    def set_enabled(self, enabled: bool) -> None:
        self.ask(self.key, {"op": "enable", "enabled": bool(enabled)}, 1.0)

    def notify_latch(self, state: JSONObject | None, by: str = "") -> None:
        if self.phase not in ("failed", "stopped", "lost"):
            self.ask(self.key, {"op": "latch", "state": state, "by": by}, 1.0)

    def counters(self) -> JSONObject:
        r = self.ask(self.key, {"op": "counters"}, 1.0)
        ok = r.get("ok") if isinstance(r, dict) else None
        return ok if isinstance(ok, dict) else {}

    def check(self, now: float) -> float | None:
        return None              # its agent watches the deadlines; its exit is an event

    def on_exit(self) -> None:
        if self.phase not in ("failed", "stopped"):
            self.mode.reported(self.name, self.generation, "failed",
                               f"process exited with status {self.exited()}")

    def stop(self, timeout: float = 2.0) -> None:
        if self.phase != "failed":
            self.phase = "stopped"
        self.stop_process(self.key, timeout)


def _result(r: JSON, resource: str) -> JSON:
    """The ok value of a resource host's reply, or its error raised; no reply, or one
    that is no JSON object, is ResourceLost (never an AttributeError in a sender)."""
    if r is None:
        raise ResourceLost(resource, "its host process does not answer")
    if not isinstance(r, dict):
        raise ResourceLost(resource, "its host process answered with no reply object")
    return wire.result(r, resource)


class ProcessResource(_Child):
    """The runtime's view of a resource entry (and its children) in an agent process."""

    state = "ready"          # "failed" when its process is gone, "stopped" when stopped

    @property
    def key(self) -> str:
        return keys.rs(self.robot, self.name)

    def children(self) -> dict[str, str]:
        kids = self.info.get("children", {})
        return {str(k): str(v) for k, v in kids.items()} if isinstance(kids, dict) else {}

    def _call(self, resource: str, body: JSONObject, timeout: float) -> JSON:
        return _result(self.ask(self.key, body, timeout + 0.5), resource)

    def command(self, sender: str, resource: str, command: JSON, timeout: float) -> JSON:
        return _result(self.ask(keys.actuator(self.robot, resource),
                                {"from": sender, "cmd": command,
                                 "timeout": max(0.0, timeout - MARGIN)}, timeout), resource)

    def configure(self, resource: str, key: str, value: JSON, timeout: float = 2.0) -> JSON:
        return self._call(resource, {"op": "configure", "resource": resource, "key": key,
                                     "value": value, "timeout": timeout}, timeout)

    def grant(self, who: str, resource: str) -> None:
        self._call(resource, {"op": "grant", "who": who, "resource": resource}, 1.0)

    def revoke(self, who: str, resource: str | None = None) -> None:
        self.ask(self.key, {"op": "revoke", "who": who, "resource": resource}, 1.0)

    def halt(self, why: str) -> None:
        """The latched STOP, in the agent's host (it stops its devices, then answers)."""
        self._call(self.name, {"op": "halt", "why": why}, 3.0)

    def release(self) -> None:
        self._call(self.name, {"op": "release"}, 1.0)

    def counters(self) -> JSONObject:
        r = self.ask(self.key, {"op": "counters"}, 1.0)
        ok = r.get("ok") if isinstance(r, dict) else None
        return ok if isinstance(ok, dict) else {}

    def on_exit(self) -> None:
        self.mode.resource_gone(self)

    def stop(self, timeout: float = 2.0) -> None:
        self.state = "stopped"
        self.mode.drop_resource(self)
        self.stop_process(self.key, timeout)


class ProcessMode:
    name = "process"

    def __init__(self, rt: RuntimeView):
        self.rt = rt
        self.port = LocalPort(rt)
        self._pending: dict[tuple[str, int], _Child] = {}
        self._resources: dict[str, ProcessResource] = {}
        self._lock = threading.Lock()
        self._pending_cond = threading.Condition(self._lock)   # _pending changed
        # name -> the join of a remote agent ({host, pid, lease...}: remote/center.py)
        self.remote: dict[str, dict[str, Any]] = {}
        self.threads = Threads()      # exit watchers, lost tokens: joined by the runtime's stop
        self.forks: ForkServer | None = None

    def child_env(self) -> dict[str, str]:
        """The environment of an agent process."""
        env = dict(os.environ)
        paths = [p for p in sys.path if p and os.path.isdir(p)]
        env["PYTHONPATH"] = os.pathsep.join(paths)
        # glibc gives each thread that allocates its own malloc arena (zenoh's threads,
        # the component's): two arenas hold the same data in 0.1-0.35 MB less RSS
        env.setdefault("MALLOC_ARENA_MAX", "2")
        if session.hub_runtime_set:              # the control center's, not a child's
            env.pop("ZENOH_RUNTIME", None)
        child_login = getattr(self.rt, "child_session", None)
        if child_login:                          # the runtime's own login (security.users)
            env["ESAIR_STD_SESSION"] = json.dumps(child_login)
        return env

    @property
    def bus(self) -> Bus:
        server = self.rt.server
        if server is None or server.bus is None:
            raise TransportError("process mode runs only beside its control endpoint")
        return server.bus

    def open(self) -> None:
        # started first: its imports overlap the runtime's own start
        self.forks = ForkServer(self.child_env())
        self.offers = SampleCaller(self.bus, keys.bs_result(self.rt.robot, "*"),
                                   lambda key: keys.name_in(key, 2))
        self.credit_lock = threading.Lock()
        # unsent: deliveries into reserved room told "delivered" whose sample could not
        # go (the session closing, the component removed meanwhile)
        self.credits = dict(reports=0, bad_reports=0, unsent=0)
        self._deliver_pubs: dict[str, Callable[[bytes], None]] = {}
        self.bus.subscribe(keys.bs_credit(self.rt.robot, "*"), self._on_credit,
                           with_key=True, garbage=self._bad_credit)
        self.bus.watch_alive(keys.alive_all(self.rt.robot), self._alive)

    def counters(self) -> JSONObject:
        """The BS's put path to the agents (``esair std inspect runtime``): the offers'
        samples and the components' reports of their room."""
        offers = getattr(self, "offers", None)
        if offers is None:
            return {}
        return {"offers": dict(offers.c), "credit_reports": dict(self.credits)}

    def _bad_credit(self, _why: str) -> None:
        self.credits["bad_reports"] += 1

    def _on_credit(self, key: str, obj: JSON) -> None:
        """A component's report of its room (on Zenoh's thread: record only)."""
        body = obj if isinstance(obj, dict) else {}
        gen, room = body.get("gen"), body.get("room")
        host = (self._component(keys.name_in(key, 2), gen)
                if isinstance(gen, int) and isinstance(room, int) else None)
        if host is None or host.remote or not isinstance(room, int):
            self.credits["bad_reports"] += 1
            return
        self.credits["reports"] += 1
        host.credit(body.get("open") is True, room, body.get("full") is True)

    def deliver(self, name: str, body: bytes) -> None:
        pub = self._deliver_pubs.get(name)
        if pub is None:
            # BLOCK, never DROP: the sender is told "delivered" once this put returns,
            # so Zenoh must not drop it under congestion (a dropped put would be a
            # delivery told and never made); the component reserved the room for it
            pub = self._deliver_pubs[name] = self.bus.publisher(
                keys.bs_deliver(self.rt.robot, name), drop=False, raw=True, express=True)
        pub(body)

    def forget(self, name: str) -> None:
        """Component ``name`` was removed: the publishers kept for it go (the BS's
        deliveries and offers to it, the answers to its puts), so the runtime's tables
        stay bounded however many differently named components come and go."""
        robot = self.rt.robot
        if self._deliver_pubs.pop(name, None) is not None:
            self.bus.undeclare(keys.bs_deliver(robot, name))
        offers = getattr(self, "offers", None)
        if offers is not None:
            offers.forget(keys.bs_offer(robot, name))
        puts = getattr(self.rt.server, "puts", None)
        if puts is not None:
            puts.forget(keys.ctl_put(robot, name))

    def _alive(self, key: str, alive: bool) -> None:
        parsed = keys.parse_alive(self.rt.robot, key)
        if parsed is None or alive:
            return
        kind, name = parsed
        rec = self.rt.bs.records.get(name)
        if rec is not None and isinstance(rec.host, ProcessComponent):
            host = rec.host
            if host.remote and host.hello.is_set():
                # not on this Zenoh thread: losing an agent revokes its grants (requests
                # to resource hosts); blocking here stalled the session's other links
                center = self.rt.center
                if center is not None:
                    self.threads.start(center.lost, host, name="esair:lost")
            elif host.phase in ("running", "busy") and host.hello.is_set():
                self.threads.start(self._token_lost, host, name="esair:lost")
        elif kind in ("sensor", "actuator", "driver") and name in self._resources:
            host = self._resources[name]
            if host.state in ("stopped", "failed") or not host.hello.is_set():
                return
            if host.remote:                      # back when it joins again (center.py)
                for res in host.children():
                    self.rt.rs.set_state(res, "lost", "its host process is gone")
            else:
                self.threads.start(self.resource_gone, host, 0.1, name="esair:lost")

    def _token_lost(self, host: ProcessComponent) -> None:
        """A component's token went. A local child must be dead too (its socket closes
        a moment before it can be reaped); a token of an older generation going late
        while this one lives is ignored. A remote agent's token is believed."""
        if host.proc is not None and not host.ended.wait(0.1):
            return
        self.reported(host.name, host.generation, "failed",
                      "its process is gone (liveliness token lost)")

    def resource_gone(self, host: ProcessResource, wait: float = 0.0) -> None:
        """A local resource host's token went or its process exited: failed (its RS
        restarts it by its policy) once its process is gone; a late token of an older
        generation is ignored."""
        if host.proc is not None and not host.ended.wait(wait):
            return
        if self._resources.get(host.name) is not host or host.state != "ready":
            return
        host.state = "failed"
        host.reason = "its host process is gone"
        self.rt.rs.failed(host.name, host.generation, host.reason)

    def hello(self, b: JSONObject) -> None:          # the agent's hello (agent_process.py)
        name, gen = b.get("name", ""), b.get("generation", 0)
        with self._lock:
            child = (self._pending.get((name, gen))
                     if isinstance(name, str) and isinstance(gen, int) else None)
        if child is None or not isinstance(name, str) or not isinstance(gen, int):
            raise ComponentError(f"no component {name!r} (generation {gen}) is starting")
        child.info = b
        pid = b.get("pid", child.pid)
        child.pid = pid if isinstance(pid, int) else child.pid
        child.hostname = str(b.get("host", ""))
        if child.rejoining and isinstance(child, ProcessResource):   # a remote resource back
            child.rejoining = False
            with self._lock:
                self._pending.pop((name, gen), None)
            why = self.rt.rs.halted
            if why is not None:          # a STOP made while it was away: before ready
                self.threads.start(self._back, child, why, name=f"esair:back:{name}")
                child.hello.set()
                child.note()
                return
            for res in child.children():
                self.rt.rs.set_state(res, "ready", "")
        child.hello.set()
        child.note()

    def _back(self, child: ProcessResource, why: str) -> None:
        """A remote resource back while the robot is STOPPED: halted, then ready."""
        try:
            child.halt(why)
        except StdError as exc:
            log.error("%s: STOP not delivered on its return: %s", child.name, exc)
        for res in child.children():
            self.rt.rs.set_state(res, "ready", "")

    def drop_resource(self, host: ProcessResource) -> None:
        """``host`` stopped: no longer one of this mode's resource hosts."""
        if self._resources.get(host.name) is host:
            del self._resources[host.name]

    def rejoin(self, host: ProcessResource) -> None:
        """A remote resource's agent joins again (remote/center.py): its next hello
        (generation 1) is that of ``host``, and sets its children ready again."""
        host.rejoining = True
        with self._lock:
            self._pending[(host.name, 1)] = host
        host.hello.clear()

    def pending_changed(self) -> None:
        with self._pending_cond:
            self._pending_cond.notify_all()

    def wait_pending(self, name: str, done: Callable[[], bool], timeout: float) -> bool:
        """Wait until generation 1 of ``name`` is starting (its hello may come) or
        ``done()``; False after ``timeout``."""
        with self._pending_cond:
            return self._pending_cond.wait_for(
                lambda: (name, 1) in self._pending or done(), timeout)

    def _component(self, name: str, generation: int) -> ProcessComponent | None:
        """The component ``name`` of that generation, deployed or still starting."""
        rec = self.rt.bs.records.get(name)
        host = rec.host if rec is not None else None
        if not isinstance(host, ProcessComponent) or host.generation != generation:
            with self._lock:
                host = self._pending.get((name, generation))
        return host if isinstance(host, ProcessComponent) else None

    def reported(self, name: str, generation: int, phase: str, reason: str) -> None:
        res = self._resources.get(name)
        if res is not None and res.generation == generation and not res.remote:
            if phase == "failed" and res.state == "ready":     # its host thread died
                res.state, res.reason = "failed", reason
                self.rt.rs.failed(name, generation, reason)
            return
        host = self._component(name, generation)
        if host is None:
            return
        if host.phase in ("failed", "stopped"):
            return
        host.phase = phase
        host.note()
        if phase == "failed":
            host.reason = reason
            if host.remote and self.remote.get(name, {}).get("restarts"):
                host.quiet = True      # its agent restarts it under its policy, or leaves
            self.port.state_changed(name, generation, phase, reason)
        else:
            self.rt.note_change()

    @contextlib.contextmanager
    def _spawning(self, child: ProcessComponent | ProcessResource) -> Iterator[None]:
        """The child spawned and greeted while it is pending (its hello finds it here);
        killed if anything in the block fails."""
        key = (child.spec.name, child.generation)
        with self._lock:
            self._pending[key] = child
            self._pending_cond.notify_all()
        try:
            child.spawn()
            child.wait_hello()
            yield
        except BaseException:
            child.kill()
            raise
        finally:
            with self._lock:
                self._pending.pop(key, None)

    def start_component(self, spec: Spec, generation: int) -> ProcessComponent:
        child = ProcessComponent(self, spec, generation)
        with self._spawning(child):
            deadline = time.monotonic() + START_TIMEOUT
            while True:                          # its first report: running or failed
                child.changed.clear()
                if child.phase != "starting":
                    break
                if child.ended.is_set():
                    child.phase = "failed"
                    child.reason = f"process exited with status {child.exited()}"
                    break
                left = deadline - time.monotonic()
                if left <= 0:
                    child.kill()
                    raise ComponentError(f"{spec.kind} {spec.name!r} did not start within"
                                         f" {START_TIMEOUT:g} s")
                sigs.wait(child.changed, left)
        return child

    def start_resource(self, spec: Spec, generation: int = 1) -> ProcessResource:
        child = ProcessResource(self, spec, generation)
        with self._spawning(child):
            self._resources[spec.name] = child
        return child

    def watch(self, now: float) -> float | None:
        return None        # agents watch their deadlines; exits and tokens are events

    def close(self) -> None:
        offers = getattr(self, "offers", None)
        if offers is not None:
            offers.close()
        for res in self._resources.values():
            res.kill()
        if self.forks is not None:
            self.forks.close()
