"""The control center's side of remote agents (process mode; docs/std-network.md).

* :func:`session` — the runtime's Zenoh session from the deployment's ``security:``
  section: TLS / logins / lease / access control on the control endpoint and, when the
  endpoint is secured, a second listener on the loopback interface for the runtime's own
  children (they are trusted as ``local``; the secured endpoint is for other computers).
* :class:`Center` — the ``ctl/join`` verb: a remote agent asks to be part of the robot.
  Its identity is checked (``security.agents`` + :mod:`esair_std.remote.registration`), then
  it is added like a local component, except that nothing is spawned: the agent is
  already running on its own computer. A behavior whose liveliness token goes is marked
  ``lost`` and its registrations are dropped; if it is not back within ``lost_grace``
  seconds it is ``failed``. A resource's children are ``lost`` and ``ready`` again when
  it joins again. A lost agent that joins again replaces its old record.
"""

from __future__ import annotations

import atexit
import logging
import os
import secrets
import socket
import tempfile
import threading
from pathlib import Path
from typing import TYPE_CHECKING, cast

from ..errors import ControlError, Refused
from ..spec import Spec
from ..transport.codec import JSONObject
from ..transport.security_config import LEASE_MS, access_control, link_inserts, session_inserts
from .registration import Verifier
from ..counters import Counters

if TYPE_CHECKING:  # pragma: no cover
    from ..deploy.model import Deployment
    from ..modes.process import ProcessMode
    from ..parts import RemoteComponent
    from ..runtime_view import RuntimeView

log = logging.getLogger("esair_std.remote")
JOIN_WAIT = 10.0
#: what a supervisor's add() did: (True, None) or (False, its exception)
_Taken = tuple[bool, "BaseException | None"]


def _free_loopback_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
        return port


def grants_for(deployment: Deployment, agent: str) -> dict[str, list[str]]:
    """What the deployment's ``allow`` lets ``agent`` read / command, and what it hosts
    (its own name): the keys Zenoh's ACL opens for it."""
    reads, commands = [], []
    for name, spec in getattr(deployment, "resources", {}).items():
        level = spec.granted(agent)
        if level is None:
            continue
        keys = [name, f"{name}.$*"]
        reads += keys
        if int(level) >= 2:
            commands += keys
    return {"reads": reads, "commands": commands, "provides": [agent, f"{agent}.$*"]}


def _local_login(options: JSONObject, rt: RuntimeView) -> None:
    """With ``users`` every session must log in, the runtime's own children too: a login
    made for this run is added to a copy of the users file; children get it in their
    environment (rt.child_session), not on their command line."""
    users = options.get("transport/auth/usrpwd/dictionary_file")
    if not users:
        return
    user, password = f"esair-local-{secrets.token_hex(4)}", secrets.token_hex(16)
    fd, path = tempfile.mkstemp(prefix="esair-users-", suffix=".txt")
    with os.fdopen(fd, "w") as f:
        f.write(Path(str(users)).read_text().rstrip("\n") + f"\n{user}:{password}\n")
    atexit.register(Path(path).unlink, missing_ok=True)
    options["transport/auth/usrpwd/dictionary_file"] = path
    rt.child_session = {"transport/auth/usrpwd/user": user,
                        "transport/auth/usrpwd/password": password}


def session(rt: RuntimeView) -> tuple[JSONObject, list[str], str | None]:
    """(zenoh options, extra listen endpoints, endpoint for local children or None)."""
    sec = getattr(rt.deployment, "security", None)
    if sec is None:
        return link_inserts(), [], None
    base = Path(rt.base_dir)
    options = session_inserts(sec, base, listen=True)
    _local_login(options, rt)
    dep = rt.deployment
    from ..lean.plain import PlainDeployment
    assert not isinstance(dep, PlainDeployment), "a plain deployment has no security section"
    grants = {a: grants_for(dep, a) for a in sec.agents}
    acl = access_control(sec, rt.robot, grants)
    if acl:
        options["access_control"] = acl
    local = f"tcp/127.0.0.1:{_free_loopback_port()}"
    return options, [local], local


def _lease_s(value: object) -> float | None:
    """The lease (s) a joining agent says its session declared (``lease_ms``), if sane."""
    if isinstance(value, (int, float)) and not isinstance(value, bool) and 100 <= value <= 600_000:
        return value / 1000.0
    return None


class Center:
    """Remote agents of one runtime (process mode)."""

    def __init__(self, rt: RuntimeView):
        self.rt = rt
        sec = getattr(rt.deployment, "security", None)
        self.sec = sec
        self.lease = (sec.lease_ms if sec else LEASE_MS) / 1000.0
        self.lost_grace = 3 * self.lease
        base = Path(rt.base_dir)

        def full(p: Path | None) -> Path | None:
            return None if p is None else (p if p.is_absolute() else base / p)

        self.verifier = (Verifier(full(sec.ca), full(sec.users))
                         if sec is not None and sec.agents else None)
        self.c = Counters(joins=0, joins_refused=0, lost=0, back=0)
        self._lock = threading.Lock()

    def _mode(self) -> ProcessMode:
        """The runtime's process mode (remote agents join only a process-mode runtime:
        the control endpoint refuses ``join`` in thread mode)."""
        mode = self.rt.mode
        if getattr(mode, "name", None) != "process":
            raise ControlError("this runtime runs in thread mode: it takes no remote agents")
        # imported here: a thread-mode runtime carries no process-mode code
        from ..modes.process import ProcessMode
        assert isinstance(mode, ProcessMode)
        return mode

    # ---- ctl/join
    def join(self, b: JSONObject) -> JSONObject:
        try:
            return self._join(b)
        except (Refused, ControlError):
            self.c.add("joins_refused")
            raise

    def _join(self, b: JSONObject) -> JSONObject:
        spec_json = b.get("spec")
        if not isinstance(spec_json, dict):
            raise ControlError("bad request: 'spec' must be an object")
        try:
            spec = Spec.from_json(spec_json)
        except TypeError as exc:
            raise ControlError(f"bad request: spec: {exc}") from None
        if spec.kind not in ("behavior", "resource"):
            raise ControlError("bad request: a remote agent hosts a behavior or a resource")
        name = spec.name
        self._check_identity(name, b.get("proof"))
        # a remote component never restarts from here: its process is not ours to start;
        # a behavior whose agent restarts it (esair std agent --restart) is not told to
        # stop when it fails (remote/remote_agent.py)
        info: JSONObject = {"host": str(b.get("host", "?"))[:64], "pid": b.get("pid"),
                "restarts": spec.kind == "behavior" and spec.restart_max > 0,
                "lease": _lease_s(b.get("lease_ms"))}
        spec = Spec.from_json({**spec.to_json(), "restart_max": 0, "base_dir": None})
        mode = self._mode()
        from ..modes.process import ProcessComponent
        if spec.kind == "resource":
            return self._join_resource(spec, info)
        rec = self.rt.bs.records.get(name)
        if rec is not None:
            host = rec.host
            if (not isinstance(host, ProcessComponent) or not host.remote
                    or host.phase not in ("lost", "failed")):
                raise ControlError(f"a {rec.spec.kind} named {name!r} is already deployed")
            host.quiet = True                     # do not tell the (returning) agent to stop
            self.rt.bs.request(self.rt.bs.remove, name)
            self.c.add("back")
        mode.remote[name] = info
        box: list[_Taken] = []
        mode.threads.start(self._add, spec, box, name=f"esair:join:{name}")
        if not mode.wait_pending(name, lambda: bool(box), JOIN_WAIT):
            raise ControlError(f"{name!r}: the behavior supervisor did not take it in time")
        if box and not box[0][0]:
            raise cast(BaseException, box[0][1])
        self.c.add("joins")
        return {"generation": 1, "robot": self.rt.robot}

    def _add(self, spec: Spec, box: list[_Taken]) -> None:
        try:
            self.rt.bs.request(self.rt.bs.add, spec, timeout=JOIN_WAIT + 20)
            box.append((True, None))
        except Exception as exc:  # noqa: BLE001 - handed to the join request
            box.append((False, exc))
            self._mode().remote.pop(spec.name, None)
        self._mode().pending_changed()

    def _join_resource(self, spec: Spec, info: JSONObject) -> JSONObject:
        mode = self._mode()
        entry = self.rt.rs.entries.get(spec.name)
        if entry is not None:
            from ..modes.process import ProcessResource
            host = entry[1]
            if not isinstance(host, ProcessResource) or not host.remote:
                raise ControlError(f"a resource named {spec.name!r} is already deployed")
            mode.remote[spec.name] = info
            mode.rejoin(host)                     # its hello sets its children ready again
            self.c.add("back")
            return {"generation": 1, "robot": self.rt.robot}
        if spec.name in self.rt.bs.records:
            raise ControlError(f"a {self.rt.bs.records[spec.name].spec.kind} named "
                               f"{spec.name!r} is already deployed")
        mode.remote[spec.name] = info
        box: list[_Taken] = []
        mode.threads.start(self._add_resource, spec, box, name=f"esair:join:{spec.name}")
        if not mode.wait_pending(spec.name, lambda: bool(box), JOIN_WAIT):
            raise ControlError(f"{spec.name!r}: the resource supervisor did not take it")
        if box and not box[0][0]:
            raise cast(BaseException, box[0][1])
        self.c.add("joins")
        return {"generation": 1, "robot": self.rt.robot}

    def _add_resource(self, spec: Spec, box: list[_Taken]) -> None:
        try:
            self.rt.rs.request(self.rt.rs.add, spec, timeout=JOIN_WAIT + 20)
            box.append((True, None))
        except Exception as exc:  # noqa: BLE001 - handed to the join request
            box.append((False, exc))
            self._mode().remote.pop(spec.name, None)
        self._mode().pending_changed()

    def _check_identity(self, name: str, proof: object) -> None:
        if self.verifier is None or self.sec is None:
            return                                 # no agents listed: the link decides
        ident = self.sec.agents.get(name)
        if ident is None:
            raise Refused(f"{name}: not an agent of this robot (security.agents)")
        self.verifier.check(self.rt.robot, name, proof, cn=ident.cn, user=ident.user)

    # ---- liveliness
    def lost(self, host: RemoteComponent) -> None:
        """A remote behavior's token went: lost now, failed after lost_grace."""
        if host.phase in ("failed", "stopped", "lost"):
            return
        host.phase, host.reason = "lost", "remote agent unreachable (liveliness token lost)"
        self.c.add("lost")
        self.rt.rs.release(host.name)
        log.warning("%s: remote agent lost", host.name)
        threading.Timer(self.lost_grace, self._grace_over, (host,)).start()

    def _grace_over(self, host: RemoteComponent) -> None:
        rec = self.rt.bs.records.get(host.name)
        current: object = rec.host if rec is not None else None     # a ProcessComponent
        if rec is not None and current is host and host.phase == "lost":
            self.rt.mode.reported(host.name, host.generation, "failed",
                                  f"remote agent unreachable for at least "
                                  f"{self.unreachable_for(host.name):g} s")

    def unreachable_for(self, name: str) -> float:
        """A lower bound of how long a remote behavior failed for being lost was silent:
        Zenoh dropped its session after the lease *the agent's session* declared (its
        own, not this center's) since the last of its keep-alives (4 a lease), so at
        least 3/4 of that lease before it was lost; then the grace (bench/std_net_lost.py)."""
        info = self._mode().remote.get(name) or {}
        lease = info.get("lease") or LEASE_MS / 1000.0
        return round(0.75 * lease + self.lost_grace, 1)
