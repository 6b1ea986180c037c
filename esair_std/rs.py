"""Resource Supervisor (RS), thesis 3.4.

Phase 1-2: deploys the deployment's resources in order, adds and removes them on
request (a removal wins at once: registrations are revoked and attached behaviors told
before the device closes). Phase 3: registration — a behavior registers for a level
(read < command < configure) that both its own ``uses`` and the resource's ``allow``
permit; this is the one table the SC and AC consult. Phase 4: ``configure`` checked
against registration and level before the resource sees it. Only control flows here;
samples and commands do not.
"""

from __future__ import annotations

import difflib
import logging
import threading
from typing import TYPE_CHECKING, Callable, Mapping

from .errors import ControlError, Refused, ResourceLost, StdError
from .level import Level, best_match
from .spec import Spec
from .parts import ResourceHost
from .supervisor import Record, Starting, Supervisor
from .transport.codec import JSON

if TYPE_CHECKING:  # pragma: no cover
    from .connections import SensorConnection

log = logging.getLogger("esair_std.rs")


def _hint(name: str, names: list[str]) -> str:
    close = difflib.get_close_matches(name, names, n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


class ResourceSupervisor(Supervisor[ResourceHost]):
    """Resource entries on the generic supervisor (supervisor.py), plus registration."""

    # a resource being removed takes no new command while its device closes: its
    # registrations end first (a behavior's are released after its stop(): bs.py)
    release_before_stop = True

    def __init__(self, start_host: Callable[[Spec, int], ResourceHost], sc: SensorConnection,
                 on_detached: Callable[[str, str], None],
                 on_attached: Callable[[str, str], None] | None = None,
                 uses_of: Callable[[str], Mapping[str, Level | str] | None] | None = None):
        super().__init__("rs", start_host)     # mode: (spec, generation) -> started host
        self._sc = sc
        self._on_detached = on_detached        # (behavior, resource): tell the behavior
        self._on_attached = on_attached or (lambda _w, _r: None)
        self._uses_of = uses_of or (lambda _w: {})
        self._lock = threading.RLock()
        self.resources: dict[str, tuple[str, str]] = {}    # resource -> (entry, kind)
        self.states: dict[str, tuple[str, str]] = {}       # resource -> (state, reason)
        self.grants: dict[tuple[str, str], Level] = {}     # (who, resource) -> level
        self.parked: dict[tuple[str, str], Level] = {}     # grants on removed resources
        self.refusals = 0
        self.refused_on: dict[str, int] = {}               # resource -> registrations refused
        self._told: dict[str, list[tuple[str, str]]] = {}                   # entry -> (who, resource) told
        self.stays_detached: dict[str, set[str]] = {}      # who -> resources back, refused
        self.halted: str | None = None         # the latched STOP's refusal (latch.py)

    @property
    def entries(self) -> dict[str, tuple[Spec, ResourceHost | Starting]]:
        """entry -> (spec, host) of every resource entry, in the order added."""
        return {n: (r.spec, r.host) for n, r in list(self.records.items())}

    def knows(self, name: str) -> bool:
        return name in self.records or name in self.resources

    # ---- phases 1-2
    def add(self, spec: Spec) -> dict[str, str]:
        """Start a resource entry (phase 1 here, later on the RS thread: ``request``);
        its children ``{name: kind}``. Behaviors that held registrations on a resource
        of the same name, removed before, are registered again (when ``uses`` and the
        new ``allow`` still permit it) and told ``attached``."""
        with self._lock:
            if spec.name in self.records or spec.name in self.resources:
                raise ControlError(f"a resource named {spec.name!r} is already deployed")
        rec = self.add_child(spec)
        kids = rec.host.children()
        if self.halted is not None:           # STOPPED: before anyone may command it
            self._halt_one(spec.name, rec.host, self.halted)
        with self._lock:
            clash = [k for k in kids if k in self.resources]
            if not clash:
                for child, kind in kids.items():
                    self.resources[child] = (spec.name, kind)
                    self.states[child] = ("ready", "")
        if clash:
            self.records.pop(spec.name, None)
            rec.host.stop()
            raise ControlError(f"a resource named {clash[0]!r} is already deployed")
        self._unpark(kids)
        return kids

    def remove(self, entry: str) -> list[str]:
        """Remove a resource entry; the behaviors that were attached (told, keep running)."""
        if entry not in self.records:
            if entry in self.resources:
                parent = self.resources[entry][0]
                raise ControlError(f"{entry!r} is part of {parent!r}: remove {parent!r}")
            raise ControlError(f"no resource {entry!r}{_hint(entry, list(self.records))}")
        self.remove_child(entry)
        return sorted({w for w, _ in self._told.pop(entry, [])})

    def stop_all(self) -> None:
        self.stop_children()
        with self._lock:
            self.resources.clear()

    # ---- the supervisor's hooks
    def released(self, name: str, rec: Record[ResourceHost], why: str) -> None:
        kids = [r for r, (e, _k) in list(self.resources.items()) if e == name]
        if why == "failed":
            # the registrations stay (the policy did not change): handles show the
            # resource lost until it is back, then work again (``restarted``)
            for res in kids:
                self.set_state(res, "lost", rec.reason)
            return
        told: set[tuple[str, str]] = set()
        with self._lock:
            for res in kids:
                del self.resources[res]
                self.states.pop(res, None)
                for (who, r) in [k for k in self.grants if k[1] == res]:
                    self.parked[(who, r)] = self.grants.pop((who, r))
                    told.add((who, r))
                for who in self._sc.drop_resource(res):
                    told.add((who, res))
                    self.parked.setdefault((who, res), Level.read)
        self._told[name] = sorted(told)
        for who, res in sorted(told):
            self._on_detached(who, res)

    def restarted(self, name: str, rec: Record[ResourceHost]) -> None:
        """The entry runs again: its children ready, every registration on them given
        to the new host (a behavior's handles work again without doing anything)."""
        kids = rec.host.children()
        if self.halted is not None:           # STOPPED: before its grants come back
            self._halt_one(name, rec.host, self.halted)
        gone = [r for r, (e, _k) in list(self.resources.items()) if e == name and r not in kids]
        with self._lock:
            for child, kind in kids.items():
                self.resources[child] = (name, kind)
            held = [(w, r) for (w, r), lv in self.grants.items()
                    if r in kids and lv >= Level.command]
        for who, res in held:
            try:
                rec.host.grant(who, res)
            except StdError as exc:
                log.error("%s: grant of %s to %s not restored: %s", name, res, who, exc)
        for child in kids:
            self.set_state(child, "ready", "")
        for res in gone:                      # the new host no longer has it: removed
            self.set_state(res, "lost", "not provided after the restart")

    def gave_up(self, name: str, rec: Record[ResourceHost]) -> None:
        why = rec.reason or "failed"
        for res, (e, _k) in list(self.resources.items()):
            if e == name:
                self.set_state(res, "lost", f"{why} (stays failed)")

    def _unpark(self, kids: dict[str, str]) -> None:
        """Registrations held on removed resources named as these: granted again when
        still permitted, else dropped (the behavior was told ``detached`` already)."""
        with self._lock:
            back = [(k, lv) for k, lv in self.parked.items() if k[1] in kids]
            for k, _lv in back:
                del self.parked[k]
        for (who, res), level in back:
            try:
                self._register(who, res, level, self._uses_of(who))
            except Refused as exc:
                log.warning("%s stays detached from %s: %s", who, res, exc)
                with self._lock:
                    self.stays_detached.setdefault(who, set()).add(res)
                continue
            if kids[res] == "sensor":
                self._sc.restore(who, res)
            self._on_attached(who, res)

    # ---- the latched STOP (latch.py)
    def halt(self, why: str) -> None:
        """Every resource host STOPPED at once (in parallel: each stops its devices),
        every command refused with ``why`` until :meth:`unhalt`."""
        self.halted = why
        hosts = [(n, r.host) for n, r in list(self.records.items()) if r.host is not None]
        threads = [threading.Thread(target=self._halt_one, args=(n, h, why),
                                    name=f"esair:halt:{n}", daemon=True)
                   for n, h in hosts[1:]]
        for t in threads:
            t.start()
        for n, h in hosts[:1]:
            self._halt_one(n, h, why)
        for t in threads:
            t.join(5.0)

    def unhalt(self) -> None:
        """Released: every host takes commands again (nothing is started)."""
        self.halted = None
        for name, rec in list(self.records.items()):
            try:
                rec.host.release()
            except StdError as exc:
                log.error("%s: release not delivered: %s", name, exc)

    @staticmethod
    def _halt_one(name: str, host: ResourceHost | Starting, why: str) -> None:
        try:
            host.halt(why)
        except StdError as exc:
            log.error("%s: STOP not delivered: %s", name, exc)

    # ---- phase 3
    def register(self, who: str, resource: str, level: Level,
                 uses: Mapping[str, Level | str] | None) -> Level:
        try:
            return self._register(who, resource, level, uses)
        except Refused:
            with self._lock:
                self.refusals += 1
                self.refused_on[resource] = self.refused_on.get(resource, 0) + 1
            raise

    def _register(self, who: str, resource: str, level: Level,
                  uses: Mapping[str, Level | str] | None) -> Level:
        """Grant ``who`` the ``level`` on ``resource`` or raise Refused with the reason.
        ``uses`` None: a reaction (its resources are fixed in the deployment)."""
        level = Level.parse(level)
        with self._lock:
            if resource not in self.resources:
                raise Refused(f"no resource {resource!r}{_hint(resource, list(self.resources))}")
            entry, kind = self.resources[resource]
            if level == Level.command and kind == "sensor":
                # configure includes command, but a sensor's host runs no write(): the
                # level is what configure() needs (docs/std.md)
                raise Refused(f"{resource!r} is a sensor: it takes no commands")
            if uses is not None:
                mine = best_match(uses, resource)
                if mine is None:
                    raise Refused(f"behavior {who!r} does not list {resource!r} in its uses")
                if level > mine:
                    raise Refused(f"behavior {who!r} lists {resource!r} for {mine} in its uses,"
                                  f" not {level}")
                allow = self.records[entry].spec.allow
                allowed = best_match(allow, who)
                if allowed is None:
                    raise Refused(f"resource {resource!r} does not allow behavior {who!r}")
                if level > allowed:
                    raise Refused(f"resource {resource!r} allows behavior {who!r} up to"
                                  f" {allowed}, not {level}")
            prev = self.grants.get((who, resource))
            self.grants[(who, resource)] = max(level, prev) if prev else level
            host = self.records[entry].host
        if level >= Level.command:
            host.grant(who, resource)
        return level

    def granted(self, who: str, resource: str) -> int:
        return int(self.grants.get((who, resource), 0))

    def release(self, who: str) -> None:
        """Every registration of ``who`` ends (it was removed, failed or restarted)."""
        with self._lock:
            keys = [k for k in self.grants if k[0] == who]
            for k in keys:
                del self.grants[k]
            for k in [k for k in self.parked if k[0] == who]:
                del self.parked[k]
            self.stays_detached.pop(who, None)
            hosts = {self.records[self.resources[r][0]].host for _w, r in keys
                     if r in self.resources and self.resources[r][0] in self.records}
        self._sc.detach(who)
        self._sc.forget(who)
        for host in hosts:
            host.revoke(who)

    # ---- phase 4
    def configure(self, who: str | None, resource: str, key: str, value: JSON) -> JSON:
        """``who`` None: the operator (the control CLI), not subject to registration."""
        host = self.host_of(resource)
        if who is not None and self.granted(who, resource) < Level.configure:
            self.refusals += 1
            have = self.grants.get((who, resource))
            raise Refused(f"behavior {who!r} is registered for {have} on {resource!r}:"
                          " configure needs the configure level" if have else
                          f"behavior {who!r} is not registered for {resource!r}")
        return host.configure(resource, key, value)

    # ---- lookups
    def host_of(self, resource: str) -> ResourceHost:
        """The host of ``resource``; ResourceLost when there is none, or while it is
        lost (its host failed and is restarting, or stays failed)."""
        with self._lock:
            r = self.resources.get(resource)
            rec = self.records.get(r[0]) if r is not None else None
            if rec is None:
                raise ResourceLost(resource, "no such resource")
            if (rec.handled >= rec.generation or isinstance(rec.host, Starting)
                    or rec.host.state in ("starting", "failed")):
                state, why = self.states.get(resource, ("lost", ""))
                raise ResourceLost(resource, f"lost: {why}" if why else "lost")
            return rec.host

    def detached_of(self, who: str) -> list[str]:
        """The resources ``who`` was detached from and is not attached to again."""
        with self._lock:
            out = {r for (w, r) in self.parked if w == who}
            out |= self.stays_detached.get(who, set())
        return sorted(out)

    def restarts_of(self, entry: str) -> int:
        rec = self.records.get(entry)
        return rec.restarts if rec is not None else 0

    def kind_of(self, resource: str) -> str | None:
        r = self.resources.get(resource)
        return r[1] if r else None

    def state_of(self, resource: str) -> str | None:
        s = self.states.get(resource)
        return s[0] if s else None

    def set_state(self, resource: str, state: str, reason: str) -> None:
        if resource in self.resources:
            self.states[resource] = (state, reason)
            self.on_change()
