"""Thread mode: every component a thread of the runtime's process; no network.

``LocalPort`` is what a hosted component calls to reach the runtime's BS/RS/SC/AC: plain
method calls. The process-mode agent's ZenohPort offers the same methods over Zenoh, and
the runtime's control server answers them by calling this same LocalPort.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Callable, Iterable

from esair_min import sigs

from ..errors import ComponentError
from ..latch import may_stop
from ..level import Level
from ..classes import component_class
from ..spec import Spec
from ..transport import keys
from ..transport.codec import JSON, JSONObject
from ..hosts.behavior_host import ComponentHost
from ..hosts.resource_host import ResourceHost

if TYPE_CHECKING:  # pragma: no cover
    from ..parts import SampleHandle
    from ..sample import Sample
    from ..runtime_view import RuntimeView

START_TIMEOUT = 10.0


class LocalPort:
    def __init__(self, rt: RuntimeView):
        self.rt = rt
        self._cmd_pubs: dict[str, Callable[[JSON], None]] = {}

    def _uses(self, who: str) -> dict[str, str] | None:
        rec = self.rt.bs.records.get(who)
        if rec is None:
            return {}                          # unknown: nothing listed, every request refused
        return None if rec.spec.kind == "reaction" else rec.spec.uses

    def _check_direct(self, who: str, resource: str) -> None:
        rec = self.rt.bs.records.get(who)
        if rec is None or rec.spec.kind != "reaction" or resource not in rec.spec.resources:
            from ..errors import Refused
            raise Refused(f"{who!r} is not a reaction listing {resource!r}")

    # registration, SC, AC
    def register(self, who: str, resource: str, level: Level | str) -> int:
        return int(self.rt.rs.register(who, resource, Level.parse(level), self._uses(who)))

    def attach_sensor(self, who: str, resource: str, handle: SampleHandle | None,
                      direct: bool = False) -> None:
        if direct:
            self._check_direct(who, resource)
            self.rt.rs.register(who, resource, Level.read, None)
        else:
            self.register(who, resource, Level.read)
        self.rt.sc.attach(who, resource, handle)

    def command(self, who: str, resource: str, command: JSON, timeout: float,
                direct: bool = False) -> JSON:
        if direct:
            self._check_direct(who, resource)
        return self.rt.ac.command(who, resource, command, timeout, direct=direct)

    def configure(self, who: str | None, resource: str, key: str, value: JSON) -> JSON:
        return self.rt.rs.configure(who, resource, key, value)

    def kind_of(self, resource: str) -> str | None:
        return self.rt.rs.kind_of(resource)

    def resource_state(self, resource: str) -> str | None:
        return self.rt.rs.state_of(resource)

    # BS
    def put(self, who: str, target: str, data: JSON, timeout: float) -> tuple[bool, str]:
        if "/" in target:                          # robot/behavior: remote/robots.py
            from ..remote import robots
            return robots.put(self.rt, who, target, data, timeout)
        return self.rt.bs.put(who, target, data, timeout)

    def get(self, who: str, target: str, timeout: float) -> tuple[bool, JSON]:
        return self.rt.bs.get(who, target, timeout)

    def state_of(self, name: str) -> str | None:
        return self.rt.state(name)

    def set_reaction(self, who: str, name: str, enabled: bool) -> None:
        self.rt.bs.set_reaction(name, enabled)

    def stop_robot(self, who: str, reason: str) -> None:
        """A component's STOP: only one whose entry says ``may_stop: true``."""
        may_stop(self.rt.bs.records, who)
        self.rt.stop_robot(reason, by=who)

    # hosts report
    def state_changed(self, name: str, generation: int, phase: str, reason: str) -> None:
        if phase == "failed":
            self.rt.bs.failed(name, generation, reason)
        self.rt.note_change()

    def publish(self, resource: str, sample: Sample) -> None:
        self.rt.sc.route(resource, sample)

    def publish_commands(self, entry: str, batch: list[JSON]) -> None:
        """The commands an entry's actuators ran, for recorders outside
        (transport/records.py): on Zenoh when the runtime serves its control endpoint
        (else nobody outside could listen)."""
        server = self.rt.server
        if server is None or server.bus is None:
            return
        pub = self._cmd_pubs.get(entry)
        if pub is None:
            pub = self._cmd_pubs[entry] = server.bus.publisher(
                keys.commands(self.rt.robot, entry), drop=True, express=False)
        pub(batch)

    def resource_state_changed(self, resource: str, state: str, reason: str) -> None:
        self.rt.rs.set_state(resource, state, reason)


class ThreadMode:
    name = "thread"

    def __init__(self, rt: RuntimeView):
        self.rt = rt
        self.port = LocalPort(rt)

    def start_component(self, spec: Spec, generation: int) -> ComponentHost:
        cls = component_class(spec.class_path, spec.base_dir, spec.where, spec.kind)
        host = ComponentHost(spec, cls, self.port, generation)
        host.start()
        if not sigs.wait(host.started, START_TIMEOUT):    # a signal on any thread interrupts it
            host.stop(0.1)
            raise ComponentError(f"{spec.kind} {spec.name!r} did not start within"
                                 f" {START_TIMEOUT:g} s")
        return host

    def start_resource(self, spec: Spec, generation: int = 1) -> ResourceHost:
        cls = component_class(spec.class_path, spec.base_dir, spec.where)
        host = ResourceHost(spec, cls, self.port)
        host.on_failed = lambda reason: self.rt.rs.failed(spec.name, generation, reason)
        host.start()                  # its device's own open timeout (resource_host.OPEN_TIMEOUT)
        return host

    def open(self) -> None:
        pass

    def hello(self, body: JSONObject) -> None:
        raise ComponentError("this runtime runs in thread mode: it hosts no agents")

    def reported(self, name: str, generation: int, phase: str, reason: str) -> None:
        raise ComponentError("this runtime runs in thread mode: it hosts no agents")

    def counters(self) -> JSONObject:
        return {}                # calls within this process: nothing to count

    def watch(self, now: float) -> float | None:
        """Check every host's deadline; seconds until one needs it again."""
        return _soonest(rec.host.check(now) for rec in list(self.rt.bs.records.values()))

    def close(self) -> None:
        pass


def _soonest(waits: Iterable[float | None]) -> float | None:
    due = [w for w in waits if w is not None]
    return min(due) if due else None
