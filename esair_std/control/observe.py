"""Control verbs for a principal outside the deployment: the remote control center
(``esair std hmi``, principal ``hmi``) reads sensors and sends commands through the RS
and the AC like any behavior.

- ``watch`` {who, resource}: register ``who`` for ``read`` on a sensor (the resource's
  ``allow`` decides) and attach it through the SC. In process mode the sensor's process
  already publishes every sample on ``esair/<robot>/sensor/<resource>``; in thread mode
  the SC hands the samples to a forwarder that publishes them there (Zenoh's DROP
  congestion control: it never waits; what Zenoh drops the watcher sees as a gap in
  ``seq``).
- ``command`` {who, resource, command, timeout}: register ``who`` for ``command`` (again
  the ``allow`` of the resource decides: ``hmi: command``) and send through the AC.
- ``restart`` {name}: remove a behavior and add it again from its own spec.
- ``describe``: per resource entry its class and, for a MIN robot link, what a page
  needs of the robot's board files (hmi/robotinfo.py: servo limits, motions and their
  frames, sensors, the balance threshold), read here where the board files are.

A principal is any name of the form ``[a-z][a-z0-9_]*`` that is not a deployed behavior
or reaction (it may not speak for one).
"""

from __future__ import annotations

import os
import re
from typing import TYPE_CHECKING, Callable, Protocol

from ..errors import ControlError, Refused
from ..level import Level
from ..sample import Sample
from ..transport import keys
from ..transport.codec import JSON, JSONObject
from ..transport.wire import Verbs

if TYPE_CHECKING:  # pragma: no cover
    from ..transport.bus import Bus
    from ..runtime_view import RuntimeView

class Server(Protocol):
    """The control endpoint, as these verbs are installed in and publish through it
    (control/control_server.py)."""

    verbs: Verbs

    @property
    def rt(self) -> RuntimeView: ...
    @property
    def bus(self) -> Bus | None: ...


#: what an outside principal asks for: everything; each resource's ``allow`` decides
PRINCIPAL_USES = {"*": Level.command}


class _Forward:
    """An SC handle (thread mode) that publishes each sample for watchers outside: one
    per sensor, attached once (under the first watcher's name) however many watch it;
    the SC marks it detached when the sensor is removed, and a later watch attaches it
    again."""

    def __init__(self, put: Callable[[JSON], None]):
        self._put = put
        self.published = 0
        self.detached = True

    def push(self, sample: Sample) -> None:
        self._put(sample.to_wire())
        self.published += 1


class Observe:
    def __init__(self, server: Server):
        self.server = server
        self.rt = server.rt
        self.forwards: dict[str, _Forward] = {}

    def install(self) -> None:
        for verb, fn in {"watch": self.v_watch, "command": self.v_command,
                         "restart": self.v_restart, "describe": self.v_describe}.items():
            self.server.verbs.add(verb, fn)

    def _who(self, b: JSONObject) -> str:
        who = b.get("who")
        if not isinstance(who, str) or not re.fullmatch(r"[a-z][a-z0-9_]*", who):
            raise ControlError("bad request: 'who' must be a name of the form [a-z][a-z0-9_]*")
        if who in self.rt.bs.records:
            raise Refused(f"{who!r} is a deployed {self.rt.bs.records[who].spec.kind}: an "
                          "outside principal may not speak for it")
        return who

    @staticmethod
    def _resource(b: JSONObject) -> str:
        res = b.get("resource")
        if not isinstance(res, str):
            raise ControlError("bad request: missing 'resource'")
        return res

    def v_watch(self, b: JSONObject) -> JSONObject:
        who, res = self._who(b), self._resource(b)
        if self.rt.rs.kind_of(res) != "sensor":
            raise Refused(f"{res!r} is not a sensor")
        self.rt.rs.register(who, res, Level.read, PRINCIPAL_USES)
        if self.rt.mode_name == "thread":
            fwd = self.forwards.get(res)
            if fwd is None:
                bus = self.server.bus
                if bus is None:
                    raise ControlError("the control endpoint is not open")
                put = bus.publisher(keys.sensor(self.rt.robot, res), drop=True,
                                    express=False)    # batched: 1 kHz sensors
                fwd = self.forwards[res] = _Forward(put)
            if fwd.detached:                   # each sample published once for all
                fwd.detached = False
                self.rt.sc.attach(who, res, fwd)
        else:
            self.rt.sc.attach(who, res, None)  # listed; the samples are on Zenoh already
        return {"key": keys.sensor(self.rt.robot, res)}

    def v_command(self, b: JSONObject) -> JSON:
        who, res = self._who(b), self._resource(b)
        if "command" not in b:
            raise ControlError("bad request: missing 'command'")
        t = b.get("timeout", 2.0)
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not 0 < t <= 60:
            raise ControlError("bad request: 'timeout' must be a number of seconds (0-60]")
        if self.rt.rs.granted(who, res) < Level.command:
            self.rt.rs.register(who, res, Level.command, PRINCIPAL_USES)
        return self.rt.ac.command(who, res, b["command"], float(t))

    def v_restart(self, b: JSONObject) -> str:
        name = b.get("name")
        rec = self.rt.bs.records.get(name) if isinstance(name, str) else None
        if rec is None or not isinstance(name, str):
            raise ControlError(f"no behavior or reaction {name!r}")
        spec = rec.spec
        self.rt.bs.request(self.rt.bs.remove, name)
        return self.rt.bs.request(self.rt.bs.add, spec).host.state

    def v_describe(self, b: JSONObject) -> JSONObject:
        out: dict[str, JSONObject] = {}
        for entry, (spec, _host) in list(self.rt.rs.entries.items()):
            d: JSONObject = {"class": spec.class_path}
            if isinstance(spec.prepared, dict) and spec.prepared.get("link") is True:
                d["link"] = True          # known where the deployment was checked
            robot = spec.options.get("robot") if isinstance(spec.options, dict) else None
            if isinstance(robot, str):
                path = os.path.join(spec.base_dir or "", robot)
                d["robot"] = os.path.abspath(path) if os.path.exists(path) else robot
            out[entry] = d
        from ..hmi.robotinfo import entries_info, min_links    # the board model: only when asked
        robots, problems = entries_info({"entries": out})
        return {"robot": self.rt.robot, "mode": self.rt.mode_name, "entries": out,
                "robots": robots, "problems": problems, "links": min_links(out)}


def install(server: Server) -> Observe:
    obs = Observe(server)
    obs.install()
    return obs
