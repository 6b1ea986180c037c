"""The component-host process: ``python -m esair_std.hosts.agent_process --connect tcp/H:P
--robot R --spec JSON``. Hosts one behavior, reaction or resource entry and joins it to
the runtime over Zenoh. A local child of the runtime and an agent on another computer
(``esair std agent --connect``) run this same code.

It exits when the runtime says stop, when its stdin closes (the local parent died), or,
with no parent's pipe to tell (``--no-stdin``), when the runtime's liveliness token goes
away and the runtime does not answer. A local child does not watch the token: its pipe
is the runtime's own word, while in a mesh of peers the token can go away and a ping go
unanswered for a while when another peer's link drops (the robot's radio), and an agent
that left then would stay failed. Zenoh
callbacks here only copy into the host's mailbox or answer at once; user code runs on the
host's thread.
"""

from __future__ import annotations

import getopt
import json
import logging
import os
import signal
import sys
import threading
import time
from typing import TYPE_CHECKING, Callable, cast

from ..errors import CommandError, ControlError, Refused, ResourceLost, StdError, TransportError
from ..level import Level
from ..sample import Sample
from ..classes import component_class
from ..spec import Spec
from ..transport import codec, keys, wire
from ..transport.codec import JSON, JSONObject
from ..transport.bus import Bus, Request, Route
from ..heap import settle
from ..transport.calls import SampleCaller, SampleServer
from ..transport.wire import Verbs

if TYPE_CHECKING:  # pragma: no cover
    from ..parts import SampleHandle
    from .behavior_host import ComponentHost
    from .resource_host import OnDone, ResourceHost

log = logging.getLogger("esair_std.agent")
MARGIN = 0.05           # the far side of a put, get or command (the BS, the actuator's host)
                        # gives up this long before the asker, whose call then returns
                        # at its timeout, answered or not (a cut link, a stopped host):
                        # a behavior whose timeouts fit its step deadline never overruns
RUNTIME_GRACE = 1.0     # seconds without the runtime's token before leaving
HELLO_S = 10.0          # how long an agent asks the runtime to take its hello


def _str(v: JSON) -> str | None:
    """A name or state the runtime answered (None: it has none)."""
    return v if isinstance(v, str) else None


def _int(v: JSON) -> int:
    """A level the runtime answered."""
    if isinstance(v, (int, float, str)):
        return int(v)
    raise TransportError(f"the runtime answered {v!r}, not a number")


class ZenohPort:
    """What a hosted component calls to reach the runtime: the LocalPort's methods,
    carried as ``ctl/<verb>`` requests, plus direct sensor subscriptions and actuator
    requests (the data flow does not pass the runtime)."""

    def __init__(self, bus: Bus, robot: str):
        self.bus = bus
        self.robot = robot
        self._pubs: dict[str, Callable[[bytes], None]] = {}
        self._cmd_pubs: dict[str, Callable[[JSON], None]] = {}
        self._calls: dict[str, SampleCaller] = {}
        self._routes: dict[str, Route] = {}      # actuator -> its route

    def _ctl(self, verb: str, body: JSONObject, timeout: float = 5.0) -> JSON:
        r = self.bus.request(keys.ctl(self.robot, verb), body, timeout)
        if r is None:
            raise TransportError(f"the runtime did not answer {verb!r} within {timeout:g} s")
        return wire.result(r, str(body.get("resource", "?")))

    def register(self, who: str, resource: str, level: Level | str) -> int:
        return _int(self._ctl("register", {"who": who, "resource": resource,
                                           "level": Level.parse(level).name}))

    def attach_sensor(self, who: str, resource: str, handle: SampleHandle | None,
                      direct: bool = False) -> None:
        self._ctl("attach", {"who": who, "resource": resource, "direct": direct})
        if handle is not None:           # None: listed only (the runtime's own view)
            push = handle.push
            self.bus.subscribe(keys.sensor(self.robot, resource),
                               lambda obj: push(Sample.from_wire(obj)))

    def command(self, who: str, resource: str, command: JSON, timeout: float,
                direct: bool = False) -> JSON:
        """The actuator's answer, within ``timeout``. When no host answers its key yet,
        the runtime says why: a resource that is lost fails at once with its reason; one
        that is ready (its host's declarations still on their way, e.g. at start-up) is
        waited for, up to the timeout."""
        deadline = time.monotonic() + timeout
        key = keys.actuator(self.robot, resource)
        route = self._routes.get(resource)
        if route is None:
            route = self._routes[resource] = self.bus.route(key)
        r = None
        # Asked at once: the matching status is only a hint (across an access-controlled
        # link it may never say "matching" although the host answers). A request that
        # comes back early found no host: then the runtime says whether the resource is
        # lost (ResourceLost at once) or coming, and the route is waited for, once.
        for attempt in range(2):
            left = deadline - time.monotonic()
            if left <= 0:
                break
            r = self.bus.request(key, {"from": who, "cmd": command,
                                       "timeout": max(0.0, left - MARGIN)}, left,
                                 express=True)
            if r is not None or deadline - time.monotonic() <= 0:
                break
            self._lost_or_coming(resource, deadline)    # early: nobody answers its key now
            if attempt == 0 and not route.ready.wait(max(0.0, deadline - time.monotonic())):
                break
        if r is None:
            raise CommandError(resource, f"no answer within {timeout:g} s")
        return wire.result(r, resource)

    def _lost_or_coming(self, resource: str, deadline: float) -> None:
        """ResourceLost with the runtime's reason unless ``resource`` is ready (or the
        runtime does not say before ``deadline``)."""
        left = deadline - time.monotonic()
        if left <= 0:
            return
        try:
            info = self._ctl("resinfo", {"resource": resource}, left)
        except StdError:
            return
        if not isinstance(info, list) or len(info) != 2:
            return                                   # the runtime does not say
        state, why = info
        if state != "ready":
            raise ResourceLost(resource, f"{state}: {why}" if why else str(state))

    def configure(self, who: str | None, resource: str, key: str, value: JSON) -> JSON:
        return self._ctl("configure", {"who": who, "resource": resource, "key": key,
                                       "value": value})

    def kind_of(self, resource: str) -> str | None:
        return _str(self._ctl("kind", {"resource": resource}))

    def resource_state(self, resource: str) -> str | None:
        return _str(self._ctl("state", {"name": resource}, 2.0))

    def put(self, who: str, target: str, data: JSON, timeout: float) -> tuple[bool, str]:
        """Through the BS, as samples (transport/calls.py: the put's fast path)."""
        calls = self._calls.get(who)
        if calls is None:
            calls = self._calls[who] = SampleCaller(
                self.bus, keys.bs_answer(self.robot, who), lambda _k: "runtime")
        try:
            r = calls.wait(keys.ctl_put(self.robot, who), "runtime",
                           {"to": target, "data": data,
                            "timeout": max(0.0, timeout - MARGIN)}, timeout)
        except StdError as exc:
            return False, exc.message
        if not isinstance(r, dict):
            return False, f"the runtime did not answer 'put' within {timeout:g} s"
        ok = r.get("ok")
        if not isinstance(ok, dict):
            return False, str(r.get("error", "the runtime's answer made no sense"))
        return bool(ok.get("delivered")), str(ok.get("reason", ""))

    def put_counters(self) -> dict[str, int]:
        """The put path's samples (transport/calls.py): sent, answered, timed out,
        answers refused."""
        out: dict[str, int] = {}
        for calls in self._calls.values():
            for k, v in calls.c.items():
                out[k] = out.get(k, 0) + v
        return out

    def get(self, who: str, target: str, timeout: float) -> tuple[bool, JSON]:
        try:
            r = self._ctl("get", {"from": who, "to": target,
                                  "timeout": max(0.0, timeout - MARGIN)}, max(0.001, timeout))
        except StdError as exc:
            return False, exc.message
        if not isinstance(r, dict):
            return False, "the runtime's answer made no sense"
        return (True, r["data"]) if r["ok"] else (False, r["reason"])

    def state_of(self, name: str) -> str | None:
        return _str(self._ctl("state", {"name": name}, 2.0))

    def set_reaction(self, who: str, name: str, enabled: bool) -> None:
        r = self.bus.request(keys.ctl(self.robot, "reaction"),
                             {"who": who, "name": name, "enabled": bool(enabled)}, 5.0)
        if r is None:
            raise ControlError("the runtime did not answer")
        wire.result(r)

    def stop_robot(self, who: str, reason: str) -> None:
        self._ctl("stop", {"who": who, "reason": reason})

    def state_changed(self, name: str, generation: int, phase: str, reason: str) -> None:
        try:
            self._ctl("report", {"name": name, "generation": generation, "phase": phase,
                                 "reason": reason}, 2.0)
        except StdError as exc:
            log.error("%s: report %s not delivered: %s", name, phase, exc)

    def publish(self, resource: str, sample: Sample) -> None:
        self.publish_encoded(resource, codec.encode(sample.to_wire()))

    def publish_encoded(self, resource: str, data: bytes) -> None:
        """A sample already encoded (``codec.encode(sample.to_wire())``): a resource
        host encodes each sample once, the copy it makes in thread mode."""
        pub = self._pubs.get(resource)
        if pub is None:
            pub = self._pubs[resource] = self.bus.publisher(keys.sensor(self.robot, resource),
                                                            raw=True)
        pub(data)

    def publish_commands(self, entry: str, batch: list[JSON]) -> None:
        """The commands an entry's actuators ran, for recorders (transport/records.py;
        never waits for a congested link)."""
        pub = self._cmd_pubs.get(entry)
        if pub is None:
            pub = self._cmd_pubs[entry] = self.bus.publisher(
                keys.commands(self.robot, entry), drop=True, express=False)
        pub(batch)

    def resource_state_changed(self, resource: str, state: str, reason: str) -> None:
        try:
            self._ctl("resstate", {"resource": resource, "state": state, "reason": reason}, 2.0)
        except StdError as exc:
            log.error("%s: state %s not delivered: %s", resource, state, exc)


class Agent:
    def __init__(self, bus: Bus, robot: str, spec: Spec, generation: int):
        self.bus = bus
        self.robot = robot
        self.spec = spec
        self.generation = generation
        self.port = ZenohPort(bus, robot)
        self.done = threading.Event()
        self.why_done = ""         # why it left (leave())
        self._wake: list[threading.Event] = []   # waits that end when it leaves
        self.host: ComponentHost | ResourceHost | None = None
        self.token_doubts = 0      # the runtime's token went away while it answered

    def leave(self, why: str) -> None:
        """Done (its process ends): the first reason given is kept in ``why_done``."""
        if not self.done.is_set():
            self.why_done = why
        self.done.set()
        for event in list(self._wake):
            event.set()

    @property
    def _component(self) -> ComponentHost:
        """The host of a behavior or reaction agent (run_component made it)."""
        return cast("ComponentHost", self.host)

    @property
    def _resource(self) -> ResourceHost:
        """The host of a resource agent (run_resource made it)."""
        return cast("ResourceHost", self.host)

    def hello(self, **extra: JSON) -> None:
        body = dict(name=self.spec.name, kind=self.spec.kind, generation=self.generation,
                    pid=os.getpid(), host=os.uname().nodename, **extra)
        # a behavior's session returns from open before the runtime's declarations may
        # have come (process.py: connect_scouted off): it waits for the runtime's hello
        # queryable to be known (Zenoh's matching status, an event), for up to HELLO_S
        deadline = time.monotonic() + HELLO_S
        route = self.bus.route(keys.ctl(self.robot, "hello"))
        self._wake.append(route.ready)         # its runtime gone (leave()): no more waiting
        r = None
        try:
            while r is None and not self.done.is_set():
                left = deadline - time.monotonic()
                if left <= 0 or not route.ready.wait(left) or self.done.is_set():
                    break
                # a runtime that dies meanwhile closes the link: Zenoh ends the query then
                r = self.bus.request(keys.ctl(self.robot, "hello"), body,
                                     max(0.001, deadline - time.monotonic()))
        finally:
            self._wake.remove(route.ready)
            route.undeclare()
        if r is None and self.done.is_set():
            raise TransportError(f"the runtime left during the hello ({self.why_done})")
        if r is None or "error" in r:
            raise TransportError(f"runtime refused hello: {r and wire.exception(r)}")

    # ---- behavior / reaction
    def run_component(self) -> None:
        from .behavior_host import ComponentHost
        try:
            cls = component_class(self.spec.class_path, self.spec.base_dir, self.spec.where,
                                  self.spec.kind)
        except StdError as exc:
            self.hello(error=exc.message)
            raise SystemExit(0) from None
        self.cls = cls
        host = self.host = ComponentHost(self.spec, cls, self.port, self.generation)
        self.bus.serve(keys.bs(self.robot, self.spec.name), self._bs_verbs().request(wire.op_of))
        self.offers = SampleServer(self.bus, keys.bs_offer(self.robot, self.spec.name),
                                   lambda _k: keys.bs_result(self.robot, self.spec.name),
                                   self._on_offer)
        # deliveries into the room this host reserves for the BS, and its reports of
        # that room (modes/process.py: ProcessComponent.deliver_reserved)
        self.delivers = dict(samples=0, bad=0)
        self.bus.subscribe(keys.bs_deliver(self.robot, self.spec.name), self._on_deliver,
                           garbage=self._bad_delivery)
        self._credit = self.bus.publisher(keys.bs_credit(self.robot, self.spec.name))
        host.on_room = self._report_room
        self.bus.token(keys.alive(self.robot, self.spec.kind, self.spec.name))
        settle()                  # before its thread runs (heap.py: no full GC pauses)
        self.hello()
        host.start()
        threading.Thread(target=self._watchdog, daemon=True, name="esair:watch").start()

    def _watchdog(self) -> None:
        """Sleeps until the host's current call could reach its deadline (check())."""
        wait = 0.0
        while not self.done.wait(wait):
            nxt = self._component.check(time.monotonic())
            wait = RUNTIME_GRACE if nxt is None else max(nxt, 0.001)

    def _report_room(self) -> None:
        self._credit({"gen": self.generation, "open": self._component.open,
                      "full": self._component.full, "room": self._component.room()})

    def _bad_delivery(self, _why: str) -> None:
        self.delivers["bad"] += 1

    def _on_deliver(self, obj: JSON) -> None:
        """A put the BS delivered into reserved room (on Zenoh's thread: enqueue only)."""
        sender = obj.get("from") if isinstance(obj, dict) else None
        if not isinstance(obj, dict) or not isinstance(sender, str) or "data" not in obj:
            self.delivers["bad"] += 1
            return
        self.delivers["samples"] += 1
        self._component.deliver_reserved(sender, obj["data"])

    def _on_offer(self, _key: str, body: JSONObject,
                  answer: Callable[[JSONObject], None]) -> None:
        """A put's first offer (transport/calls.py): answered before the behavior's
        thread is woken."""
        r = self._component.offer(str(body.get("from")), body.get("data"), wake=False)
        answer({"r": r})
        if r == "delivered":
            self._component.wake()

    def _bs_verbs(self) -> Verbs:
        """The ``bs/<name>`` endpoint: what the runtime's BS asks the hosted component
        (answered on Zenoh's thread: each verb only enqueues or reads)."""
        verbs = Verbs(unknown="unknown op {verb!r}")
        # the host is looked up at each request: a remote agent restarts its behavior
        # under its policy in a new host (remote/remote_agent.py)
        def host() -> ComponentHost:
            return self._component

        def provide(b: JSONObject, answer: wire.Answer) -> None:
            if host().request_provide(str(b.get("from")),
                                    lambda v: answer(wire.ok(list(v)))) != "queued":
                answer(wire.ok(["busy", host().state]))

        def take(b: JSONObject, answer: wire.Answer) -> None:    # a put its sender waits for
            if host().request_take(str(b.get("from")), b.get("data"),
                                 lambda v: answer(wire.ok(list(v)))) != "queued":
                answer(wire.ok(["busy", host().state]))

        verbs.add("offer", lambda b: host().offer(str(b.get("from")), b.get("data")))
        verbs.later("provide", provide)
        verbs.later("take", take)
        verbs.add("state", lambda _b: host().state)
        verbs.add("detached", lambda b: host().notify_detached(str(b.get("resource"))))
        verbs.add("attached", lambda b: host().notify_attached(str(b.get("resource"))))
        verbs.add("enable", lambda b: host().set_enabled(bool(b.get("enabled"))))
        verbs.add("latch", lambda b: host().notify_latch(
            st if isinstance(st := b.get("state"), dict) else None, str(b.get("by", ""))))
        verbs.add("counters", lambda _b: {**host().counters(), "offer_samples": dict(self.offers.c),
                                          "deliver_samples": dict(self.delivers),
                                          "put_samples": self.port.put_counters()})
        verbs.later("stop", self._stop)
        return verbs

    def _stop(self, _b: JSONObject, answer: wire.Answer) -> None:
        answer(wire.ok())
        self.leave("stopped by the control center")

    # ---- resource entry
    def run_resource(self) -> None:
        from ..resource import Driver
        from .resource_host import ResourceHost
        try:
            cls = component_class(self.spec.class_path, self.spec.base_dir, self.spec.where)
            host = self.host = ResourceHost(self.spec, cls, self.port)
            host.on_failed = self._resource_failed                # exits non-zero: main()
            kids = host.start()
        except StdError as exc:
            self.hello(error=exc.message)
            raise SystemExit(0) from None
        settle()                  # the device open, before commands come (heap.py)
        for name, kind in kids.items():
            if kind == "actuator":
                self.bus.serve(keys.actuator(self.robot, name), self._on_actuator,
                               express=True)
        self.bus.serve(keys.rs(self.robot, self.spec.name), self._rs_verbs().request(wire.op_of))
        kind = "driver" if isinstance(host.driver, Driver) else next(iter(kids.values()))
        self.bus.token(keys.alive(self.robot, kind, self.spec.name))
        self.hello(children=kids)

    def _resource_failed(self, reason: str) -> None:
        """The resource host's thread died: the runtime told why, then this process ends
        (status 1), and its RS restarts it by its policy."""
        self.port.state_changed(self.spec.name, self.generation, "failed", reason)
        self.leave(f"its resource failed: {reason}")

    def _on_actuator(self, req: Request) -> None:
        b = req.body
        if b is None:
            req.reply(wire.error(ControlError(f"bad request: {req.error}")))
            return
        res = req.key.rsplit("/", 1)[-1]
        slot = self._resource.slots.get(res)
        who = str(b.get("from"))
        if slot is None or who not in slot.granted:
            req.reply(wire.error(Refused(f"behavior {who!r} is not registered to command "
                                         f"{res!r}")))
            return
        t = b.get("timeout", 1.0)
        self._resource.submit(res, "write", (b.get("cmd"),), self._answer(req.reply, res),
                              float(t) if isinstance(t, (int, float)) else 1.0,
                              copy=False,     # just decoded from the wire: its own already
                              sender=who)

    @staticmethod
    def _answer(answer: wire.Answer, resource: str) -> OnDone:
        """A resource host's ``on_done(ok, value)`` as a reply."""
        def done(ok: bool, value: JSON | StdError) -> None:
            answer(wire.ok(value) if ok and not isinstance(value, StdError)
                   else wire.error(wire.failure(value, resource)))
        return done

    def _rs_verbs(self) -> Verbs:
        """The ``rs/<entry>`` endpoint: what the runtime's RS asks the resource host."""
        host, verbs = self._resource, Verbs(unknown="unknown op {verb!r}")

        def configure(b: JSONObject, answer: wire.Answer) -> None:
            res = str(b.get("resource"))
            host.submit(res, "configure", (str(b.get("key")), b.get("value")),
                        self._answer(answer, res), 2.0)

        verbs.later("configure", configure)
        verbs.add("grant", lambda b: host.grant(str(b.get("who")), str(b.get("resource"))))
        verbs.add("revoke", lambda b: host.revoke(
            str(b.get("who")), None if (r := b.get("resource")) is None else str(r)))
        verbs.add("counters", lambda _b: host.counters())
        verbs.later("halt", self._halt)
        verbs.add("release", lambda _b: host.release())
        verbs.later("stop", self._stop)
        return verbs

    def _halt(self, b: JSONObject, answer: wire.Answer) -> None:
        """The latched STOP: commands refused at once (here, on Zenoh's thread); the
        devices stopped on a thread of its own (a link waits for its ``x`` reply), then
        the runtime answered."""
        why = str(b.get("why") or "stopped")
        self._resource.halted = why

        def run() -> None:
            self._resource.halt(why)
            answer(wire.ok())
        threading.Thread(target=run, name="esair:halt", daemon=True).start()

    # ---- leaving
    def watch_runtime(self) -> None:
        lost: dict[str, float | None] = {"t": None}

        def on_alive(key: str, alive: bool) -> None:
            if keys.parse_alive(self.robot, key) == ("runtime", "runtime"):
                lost["t"] = None if alive else time.monotonic()
                if not alive:
                    threading.Timer(RUNTIME_GRACE, self._runtime_gone, (lost,)).start()
        self.bus.watch_alive(keys.alive(self.robot, "runtime", "runtime"), on_alive)

    def _runtime_gone(self, lost: dict[str, float | None]) -> None:
        """The runtime's token has been away for RUNTIME_GRACE. The token is only a hint:
        in a mesh of peers its withdrawal can also come when another peer's link drops
        (the robot's radio), while this agent's own link to the runtime stays up. So the
        agent asks the runtime (``ping``) before it leaves, and leaves only when nobody
        answers; while the token stays away it asks again every RUNTIME_GRACE."""
        if lost["t"] is None or self.done.is_set():
            return
        if self._runtime_answers():
            self.token_doubts += 1
            log.info("%s: the runtime's token went away, but the runtime answers; staying",
                     self.spec.name)
            threading.Timer(RUNTIME_GRACE, self._runtime_gone, (lost,)).start()
            return
        log.warning("%s: the runtime is gone; leaving", self.spec.name)
        self.leave("the runtime is gone")

    def _runtime_answers(self) -> bool:
        try:
            r = self.bus.request(keys.ctl(self.robot, "ping"), {}, RUNTIME_GRACE)
        except StdError:
            return False
        ok = r.get("ok") if isinstance(r, dict) else None
        return isinstance(ok, dict) and ok.get("robot") == self.robot


def _stdin_watch(agent: Agent) -> None:
    """The runtime's end of the pipe closes when the runtime's process ends, however it
    ends (SIGKILL included): the agent leaves, a hello under way included."""
    try:
        while sys.stdin.buffer.read(1):
            pass
    except (OSError, ValueError):
        pass
    agent.leave("the runtime is gone")


USAGE = """usage: python -m esair_std.hosts.agent_process --connect tcp/HOST:PORT --robot ROBOT
                                     --spec JSON [--generation N] [--no-stdin]
                                     [--session-options JSON]

  --connect          the runtime's endpoint, tcp/HOST:PORT
  --robot            the robot's name
  --spec             the component's spec (JSON)
  --generation       the component's generation (default 1)
  --no-stdin         do not leave when stdin closes; leave when the runtime's token goes
                     and the runtime does not answer (a local child watches its pipe)
  --session-options  extra Zenoh config (JSON)
"""
_LONG = ["connect=", "robot=", "spec=", "generation=", "no-stdin", "session-options=", "help"]


class _Args:
    """The command line of :func:`main`, read with getopt (argparse would cost every
    agent process 0.3-0.4 MB of RSS): a bad one is exit status 2 with the usage."""

    def __init__(self, argv: list[str]):
        try:
            opts, rest = getopt.getopt(argv, "h", _LONG)
            if rest:
                raise getopt.GetoptError(f"unexpected argument {rest[0]!r}")
            o = dict(opts)
            if "-h" in o or "--help" in o:
                sys.stdout.write(USAGE)
                raise SystemExit(0)
            missing = [k for k in ("--connect", "--robot", "--spec") if k not in o]
            if missing:
                raise getopt.GetoptError(f"the following arguments are required: "
                                         f"{', '.join(missing)}")
            self.connect, self.robot, self.spec = o["--connect"], o["--robot"], o["--spec"]
            generation = o.get("--generation", "1")
            if not generation.isdigit():
                raise getopt.GetoptError(f"--generation {generation!r} is not a number")
            self.generation = int(generation)
        except getopt.GetoptError as exc:
            sys.stderr.write(f"{USAGE}python -m esair_std.hosts.agent_process: error: {exc}\n")
            raise SystemExit(2) from None
        self.no_stdin = "--no-stdin" in o
        self.session_options = o.get("--session-options", "{}")


def main(argv: list[str] | None = None) -> int:
    # A terminal's Ctrl-C reaches the whole process group: the runtime stops its agents
    # itself (one line, no traceback from each of them).
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    a = _Args(sys.argv[1:] if argv is None else argv)
    logging.basicConfig(level=logging.WARNING, format="%(name)s: %(message)s")
    spec = Spec.from_json(json.loads(a.spec))
    options = json.loads(a.session_options)
    options.update(json.loads(os.environ.get("ESAIR_STD_SESSION") or "{}"))  # a login
    bus = Bus(connect=[a.connect], options=options, runtime=a.connect)
    agent = Agent(bus, a.robot, spec, a.generation)
    if not a.no_stdin:
        threading.Thread(target=_stdin_watch, args=(agent,), daemon=True).start()
    code = 0
    try:
        if a.no_stdin:              # no parent's pipe: the token (and a ping) says
            agent.watch_runtime()
        if spec.kind == "resource":
            agent.run_resource()
        else:
            agent.run_component()
        agent.done.wait()
    except SystemExit:
        code = 0
    except StdError as exc:
        if not agent.done.is_set():     # else its runtime left: nothing to say
            log.error("%s: %s", spec.name, exc)
            code = 1
    finally:
        if agent.host is not None:
            agent.host.stop(1.0)
        bus.close()
    if agent.host is not None and getattr(agent.host, "state", "") == "failed":
        code = 1                  # its component failed: a supervisor (systemd) may restart
    os._exit(code)


if __name__ == "__main__":
    sys.exit(main())
