"""A remote agent: one behavior or resource on another computer (``esair std agent``).

It is the component-host process of process mode (:mod:`esair_std.hosts.agent_process`) with
three differences:

* its session is a Zenoh **client** of the control center (it listens on nothing; all
  its traffic goes through the control center's session, where the access control is);
* before its hello it **joins** (``ctl/join``): the control center checks who it is
  (a proof signed with its certificate's key, or an HMAC of its password) and adds it
  like a local component, spawning nothing;
* it **outlives partitions**: when the control center's liveliness token goes it keeps
  running (its puts fail, counted; its sensor handles see no samples); when the token
  comes back it joins again and registers again for every resource it had registered
  for, by itself. It leaves when told to stop or on SIGINT/SIGTERM.
"""

from __future__ import annotations

import json
import logging
import os
import signal
import threading
import time
from pathlib import Path
from typing import TYPE_CHECKING, Callable, cast

from esair_min import sigs

from ..errors import StdError, TransportError
from ..level import Level
from ..hosts.agent_process import Agent, ZenohPort
from ..spec import Spec
from ..transport import keys, wire
from ..transport.bus import Bus
from ..transport.codec import JSON, JSONObject
from ..transport.security_config import LEASE_MS, link_inserts, session_inserts
from ..counters import Counters
from ..restart_window import RestartWindow

if TYPE_CHECKING:  # pragma: no cover
    from ..deploy.security import SecuritySpec
    from ..parts import SampleHandle

log = logging.getLogger("esair_std.remote")


class RemotePort(ZenohPort):
    """ZenohPort that remembers registrations so that they can be made again."""

    def __init__(self, bus: Bus, robot: str):
        super().__init__(bus, robot)
        self.registered: dict[str, Level] = {}     # resource -> level
        self.attached: set[str] = set()            # sensors attached (subscribed once)
        self.on_failed: Callable[[str], None] | None = None    # its behavior failed (RemoteAgent)

    def register(self, who: str, resource: str, level: Level | str) -> int:
        out = super().register(who, resource, level)
        lv = Level.parse(level)
        self.registered[resource] = max(lv, self.registered.get(resource, lv))
        return out

    def attach_sensor(self, who: str, resource: str, handle: SampleHandle | None,
                      direct: bool = False) -> None:
        super().attach_sensor(who, resource, handle, direct)
        self.attached.add(resource)

    def state_changed(self, name: str, generation: int, phase: str, reason: str) -> None:
        super().state_changed(name, generation, phase, reason)
        if phase == "failed" and self.on_failed is not None:
            self.on_failed(reason)              # told or not (a cut link): the agent's policy

    def register_again(self, who: str) -> list[str]:
        """After a re-join: every registration and attachment again; what failed."""
        failed = []
        for resource, level in list(self.registered.items()):
            try:
                super().register(who, resource, level)
            except StdError as exc:
                failed.append(f"{resource}: {exc}")
        for resource in list(self.attached):
            try:
                self._ctl("attach", {"who": who, "resource": resource, "direct": False})
            except StdError as exc:
                failed.append(f"{resource}: {exc}")
        return failed


class RemoteAgent(Agent):
    port: RemotePort

    def __init__(self, bus: Bus, robot: str, spec: Spec, proof_fn: Callable[[], JSON], hostname: str,
                 lease_ms: int = LEASE_MS):
        super().__init__(bus, robot, spec, 1)
        self.lease_ms = lease_ms                   # its session's: when the center drops it
        self.port = RemotePort(bus, robot)
        self.proof_fn = proof_fn
        self.hostname = hostname
        self.joined = threading.Event()
        self.c = Counters(joins=0, partitions=0, restarts=0)
        self._rejoin_lock = threading.Lock()
        self._restarts = RestartWindow(int(spec.restart_max or 0), float(spec.restart_within or 0.0))
        if spec.kind != "resource":
            self.port.on_failed = self._failed

    def join(self) -> None:
        body = {"spec": self.spec.to_json(), "proof": self.proof_fn(),
                "host": self.hostname, "pid": os.getpid(), "lease_ms": self.lease_ms}
        r = self.bus.request(keys.ctl(self.robot, "join"), body, 15.0)
        if r is None:
            raise TransportError(f"the control center of robot {self.robot!r} did not answer"
                                 " the join")
        if "error" in r:
            raise TransportError(f"join refused: {wire.exception(r)}")
        self.c.add("joins")

    def hello(self, **extra: JSON) -> None:
        t0 = time.perf_counter()
        self.join()
        body: JSONObject = dict(name=self.spec.name, kind=self.spec.kind, generation=self.generation,
                    pid=os.getpid(), host=self.hostname, **extra)
        r = self.bus.request(keys.ctl(self.robot, "hello"), body, 10.0)
        if r is None or "error" in r:
            raise TransportError(f"runtime refused hello: {r and wire.exception(r)}")
        self.joined.set()
        log.info("%s joined robot %r in %.1f ms", self.spec.name, self.robot,
                 (time.perf_counter() - t0) * 1e3)

    def watch_runtime(self) -> None:
        def on_alive(key: str, alive: bool) -> None:
            if keys.parse_alive(self.robot, key) != ("runtime", "runtime"):
                return
            if not alive:
                if self.joined.is_set():
                    self.joined.clear()
                    self.c.add("partitions")
                    log.warning("%s: the control center is unreachable; waiting for it",
                                self.spec.name)
            elif self.c["joins"] and not self.joined.is_set():
                threading.Thread(target=self._rejoin, daemon=True, name="esair:rejoin").start()
        self.bus.watch_alive(keys.alive(self.robot, "runtime", "runtime"), on_alive)

    def _rejoin(self) -> None:
        with self._rejoin_lock:
            while not self.joined.is_set() and not self.done.is_set():
                try:
                    if self.spec.kind == "resource":
                        self.hello(children={**self._resource.children()})
                    else:
                        self.hello()
                        state = self.host.state if self.host is not None else "running"
                        self.port.state_changed(self.spec.name, self.generation,
                                                "running" if state == "busy" else state,
                                                getattr(self.host, "reason", ""))
                        failed = self.port.register_again(self.spec.name)
                        for f in failed:
                            log.error("%s: registration not made again: %s", self.spec.name, f)
                    log.warning("%s: joined the control center again", self.spec.name)
                except StdError as exc:
                    log.error("%s: join again failed: %s; retrying", self.spec.name, exc)
                    time.sleep(0.5)


    # ---- its behavior's restart policy (the control center never restarts a remote one)
    def _failed(self, reason: str) -> None:
        """Its behavior failed (on the behavior's or the watchdog's thread). With a
        policy (``--restart``) it is restarted within it, on a thread of its own; past
        it the control center is told why and the agent leaves (status 1). Without one,
        the control center tells the agent to stop (status 1)."""
        most, within = self.spec.restart_max, self.spec.restart_within
        if not most or self.done.is_set():
            return
        again = self._restarts.allow(time.monotonic())
        if not again:
            log.error("%s: failed (%s); past its restart policy (%d within %g s): it "
                      "stays failed", self.spec.name, reason, most, within)
        threading.Thread(target=self._after_failure, args=(reason, again), daemon=True,
                         name="esair:restart").start()

    def _after_failure(self, reason: str, again: bool) -> None:
        """Tells the control center that its behavior failed (again until it answers:
        the link may be cut); then either leaves, or joins again (the center replaces a
        failed record) and runs the behavior in a new host."""
        from ..hosts.behavior_host import ComponentHost
        self._component.stop(1.0)
        with self._rejoin_lock:
            while not self.done.is_set():
                try:
                    self.port._ctl("report", {"name": self.spec.name,
                                              "generation": self.generation,
                                              "phase": "failed", "reason": reason}, 2.0)
                    if not again:
                        break
                    self.joined.clear()
                    host = ComponentHost(self.spec, self.cls, self.port, self.generation)
                    host.on_room = self._report_room
                    self.host = host
                    self.hello()
                    break
                except StdError as exc:
                    log.warning("%s: waits for the control center: %s", self.spec.name, exc)
                    self.done.wait(0.5)
            if self.done.is_set() or not again:
                self.leave(f"its behavior failed: {reason}")
                return
            self.c.add("restarts")
            log.warning("%s: restarted after it failed (%s): restart %d of at most %d "
                        "within %g s", self.spec.name, reason, len(self._restarts),
                        self.spec.restart_max, self.spec.restart_within)
            self._component.start()


def component_spec(name: str, class_path: str, kind: str, uses: dict[str, Level | str],
                   period: float | None, options: JSONObject,
                   allow: dict[str, Level | str] | None = None,
                   restart: tuple[int, float] = (0, 0.0)) -> Spec:
    return Spec(kind, name, class_path, dict(options), os.getcwd(), period=period,
                has_period=period is not None,
                restart_max=int(restart[0]), restart_within=float(restart[1]),
                uses={k: Level.parse(v).name for k, v in uses.items()},
                allow={k: Level.parse(v).name for k, v in (allow or {}).items()})


def session_options(sec: SecuritySpec | None) -> JSONObject:
    """The remote agent's Zenoh options: a client, the link settings, its credentials."""
    opts: JSONObject = {"mode": "client", "listen/endpoints": [], **link_inserts()}
    opts.update(session_inserts(sec, ".", listen=False))
    return opts


def proof_maker(robot_fn: Callable[[], str], name: str,
                sec: SecuritySpec | None) -> Callable[[], JSONObject | None]:
    def proof() -> JSONObject | None:
        if sec is None:
            return None
        from .registration import prove_with_cert, prove_with_password   # hashlib: OpenSSL
        if sec.cert is not None:
            assert sec.key is not None                  # SecuritySpec: cert and key go together
            return prove_with_cert(robot_fn(), name, sec.cert, sec.key)
        if sec.user is not None:
            assert sec.password_file is not None        # ... and user and password_file
            password = Path(sec.password_file).read_text().strip()
            return prove_with_password(robot_fn(), name, sec.user, password)
        return None
    return proof


def find_robot(bus: Bus, endpoint: str) -> str:
    for wait in (2.0, 3.0):
        r = cast("JSONObject | None", bus.request("esair/*/ctl/ping", {}, wait))  # an object
        if r is not None and "ok" in r:
            ok = cast(JSONObject, r["ok"])             # ping's answer: {"robot", ...}
            return str(ok["robot"])
    raise TransportError(f"no ESAIR STD control center answers on {endpoint} (with access "
                         "control on, name the robot: --robot NAME)")


def run(endpoint: str, name: str, class_path: str, kind: str,
        uses: dict[str, Level | str] | None = None, period: float | None = None,
        options: JSONObject | None = None, robot: str | None = None,
        sec: SecuritySpec | None = None, hostname: str | None = None,
        allow: dict[str, Level | str] | None = None, ready: Callable[[RemoteAgent], None] | None = None,
        restart: tuple[int, float] = (0, 0.0),
        left: Callable[[RemoteAgent], None] | None = None) -> int:
    """Run the agent until it is told to stop or signalled; its exit status. ``ready``
    (agent): called once it joined and runs its component; ``left`` (agent): once it is
    done (``agent.why_done`` says why)."""
    spec = component_spec(name, class_path, kind, uses or {}, period, options or {}, allow,
                          (int(restart[0]), float(restart[1])))     # JSON: a list
    try:
        bus = Bus(connect=[endpoint], options=session_options(sec), runtime=endpoint)
    except TransportError as exc:
        raise TransportError(f"cannot reach the control center at {endpoint}: "
                             f"{str(exc).split(': ', 1)[-1]} (is `esair std run` listening "
                             "there?)") from None
    try:
        robot = robot or find_robot(bus, endpoint)
        agent = RemoteAgent(bus, robot, spec, proof_maker(lambda: robot, name, sec),
                            hostname or os.uname().nodename,
                            sec.lease_ms if sec is not None else LEASE_MS)
        for sig in (signal.SIGINT, signal.SIGTERM):      # an inherited ignore stays
            sigs.install(sig, lambda *_: agent.leave("interrupted"))
        agent.watch_runtime()
        if kind == "resource":
            agent.run_resource()
        else:
            agent.run_component()
        if ready is not None:
            ready(agent)
        while not agent.done.wait(0.2):
            pass
        if left is not None:
            left(agent)
        # its component failed: exit status 1, so a supervisor of the process (systemd's
        # Restart=on-failure) starts it again
        return 1 if getattr(agent.host, "state", "") == "failed" else 0
    finally:
        host = locals().get("agent")
        if host is not None and host.host is not None:
            host.host.stop(1.0)
        bus.close()


_PATHS = ("ca", "cert", "key", "users", "password_file")


class _Security:
    """A security section already validated by ``esair std agent`` (its pydantic model,
    dumped to JSON): the fields the transport reads, without loading pydantic here."""

    def __init__(self, fields: dict[str, object]):
        for k, v in fields.items():
            setattr(self, k, Path(str(v)) if k in _PATHS and v is not None else v)


def joined_line(agent: RemoteAgent, endpoint: str) -> str:
    """What ``esair std agent`` prints once it joined: who, where, what it hosts."""
    spec = agent.spec
    head = (f"agent {spec.name!r} joined robot {agent.robot!r} at {endpoint} as host "
            f"{agent.hostname!r}")
    if spec.kind == "resource":
        kids = agent._resource.children()
        if list(kids) == [spec.name]:
            what = f"{kids[spec.name]} {spec.class_path}"
        else:
            what = (f"driver {spec.class_path} ("
                    + ", ".join(f"{k}: {v}" for k, v in kids.items()) + ")")
        grants = ", ".join(f"{k}={v}" for k, v in spec.allow.items()) or "nobody"
        what += f", allows {grants}"
        remove = "remove-resource"
    else:
        uses = ", ".join(f"{k}={v}" for k, v in spec.uses.items()) or "no resource"
        what = f"{spec.kind} {spec.class_path}, uses {uses}"
        remove = "remove"
    return f"{head}: {what}; runs until Ctrl-C or `esair std {remove} {spec.name}`"


def main_json(argv: list[str]) -> int:
    """``python -m esair_std.remote.remote_agent JSON``: ``run(**JSON)``, an error as one
    ``error: ...`` line and status 1 (as the CLI). ``esair std agent`` validates its
    options, then becomes this process (os.execv), so a remote agent carries neither
    the CLI nor pydantic (RSS per component process, docs/std.md)."""
    import sys
    kw = json.loads(argv[0])
    logging.basicConfig(level=getattr(logging, kw.pop("log", "INFO")),
                        format="%(name)s: %(message)s")
    if kw.get("sec"):
        kw["sec"] = _Security(kw["sec"])
    endpoint = kw["endpoint"]

    def ready(agent: RemoteAgent) -> None:
        print(joined_line(agent, endpoint), file=sys.stderr, flush=True)

    def left(agent: RemoteAgent) -> None:
        print(f"agent {agent.spec.name!r} left robot {agent.robot!r}: "
              f"{agent.why_done or 'stopped'}", file=sys.stderr, flush=True)
    try:
        return run(**kw, ready=ready, left=left)
    except StdError as exc:
        print(f"error: {exc}", file=sys.stderr, flush=True)
        return 1
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":  # pragma: no cover
    import sys
    status = main_json(sys.argv[1:])
    sys.stdout.flush()
    sys.stderr.flush()
    # no interpreter finalization: Zenoh's threads may still be calling into Python, and
    # a thread ended under them aborted the process ("FATAL: exception not rethrown")
    os._exit(status)
