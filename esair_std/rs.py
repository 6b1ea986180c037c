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
import threading
from typing import Any, Callable

from .errors import ControlError, Refused, ResourceLost
from .level import Level, best_match
from .spec import Spec


def _hint(name: str, names: list[str]) -> str:
    close = difflib.get_close_matches(name, names, n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


class ResourceSupervisor:
    def __init__(self, start_host: Callable[[Spec], Any], sc: Any,
                 on_detached: Callable[[str, str], None]):
        self._start_host = start_host          # mode: Spec -> started host (children known)
        self._sc = sc
        self._on_detached = on_detached        # (behavior, resource): tell the behavior
        self._lock = threading.RLock()
        self.entries: dict[str, tuple[Spec, Any]] = {}     # entry -> (spec, host)
        self.resources: dict[str, tuple[str, str]] = {}    # resource -> (entry, kind)
        self.states: dict[str, tuple[str, str]] = {}       # resource -> (state, reason)
        self.grants: dict[tuple[str, str], Level] = {}     # (who, resource) -> level
        self.refusals = 0
        self.refused_on: dict[str, int] = {}               # resource -> registrations refused

    # ---- phases 1-2
    def add(self, spec: Spec) -> dict[str, str]:
        with self._lock:
            if spec.name in self.entries or spec.name in self.resources:
                raise ControlError(f"a resource named {spec.name!r} is already deployed")
            host = self._start_host(spec)
            kids = host.children()
            clash = [k for k in kids if k in self.resources]
            if clash:
                host.stop()
                raise ControlError(f"a resource named {clash[0]!r} is already deployed")
            self.entries[spec.name] = (spec, host)
            for child, kind in kids.items():
                self.resources[child] = (spec.name, kind)
                self.states[child] = ("ready", "")
            return kids

    def remove(self, entry: str) -> list[str]:
        """Remove a resource entry; the behaviors that were attached (told, keep running)."""
        with self._lock:
            if entry not in self.entries:
                if entry in self.resources:
                    parent = self.resources[entry][0]
                    raise ControlError(f"{entry!r} is part of {parent!r}: remove {parent!r}")
                raise ControlError(f"no resource {entry!r}{_hint(entry, list(self.entries))}")
            spec, host = self.entries.pop(entry)
            kids = [r for r, (e, _k) in self.resources.items() if e == entry]
            told: set[tuple[str, str]] = set()
            for res in kids:
                del self.resources[res]
                self.states.pop(res, None)
                for (who, r) in [k for k in self.grants if k[1] == res]:
                    del self.grants[(who, r)]
                    told.add((who, r))
                for who in self._sc.drop_resource(res):
                    told.add((who, res))
        for who, res in sorted(told):
            self._on_detached(who, res)
        host.stop()
        return sorted({w for w, _ in told})

    def stop_all(self) -> None:
        for entry in reversed(list(self.entries)):
            _spec, host = self.entries.pop(entry)
            host.stop()
        self.resources.clear()

    # ---- phase 3
    def register(self, who: str, resource: str, level: Level, uses: dict | None) -> Level:
        try:
            return self._register(who, resource, level, uses)
        except Refused:
            with self._lock:
                self.refusals += 1
                self.refused_on[resource] = self.refused_on.get(resource, 0) + 1
            raise

    def _register(self, who: str, resource: str, level: Level, uses: dict | None) -> Level:
        """Grant ``who`` the ``level`` on ``resource`` or raise Refused with the reason.
        ``uses`` None: a reaction (its resources are fixed in the deployment)."""
        level = Level.parse(level)
        with self._lock:
            if resource not in self.resources:
                raise Refused(f"no resource {resource!r}{_hint(resource, list(self.resources))}")
            entry, kind = self.resources[resource]
            if level > Level.read and kind == "sensor":
                raise Refused(f"{resource!r} is a sensor: it takes no commands")
            if uses is not None:
                mine = best_match(uses, resource)
                if mine is None:
                    raise Refused(f"behavior {who!r} does not list {resource!r} in its uses")
                if level > mine:
                    raise Refused(f"behavior {who!r} lists {resource!r} for {mine} in its uses,"
                                  f" not {level}")
                allow = self.entries[entry][0].allow
                allowed = best_match(allow, who)
                if allowed is None:
                    raise Refused(f"resource {resource!r} does not allow behavior {who!r}")
                if level > allowed:
                    raise Refused(f"resource {resource!r} allows behavior {who!r} up to"
                                  f" {allowed}, not {level}")
            prev = self.grants.get((who, resource))
            self.grants[(who, resource)] = max(level, prev) if prev else level
            host = self.entries[entry][1]
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
            hosts = {self.entries[self.resources[r][0]][1] for _w, r in keys
                     if r in self.resources}
        self._sc.detach(who)
        for host in hosts:
            host.revoke(who)

    # ---- phase 4
    def configure(self, who: str | None, resource: str, key: str, value: Any) -> Any:
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
    def host_of(self, resource: str) -> Any:
        with self._lock:
            if resource not in self.resources:
                raise ResourceLost(resource, "no such resource")
            return self.entries[self.resources[resource][0]][1]

    def kind_of(self, resource: str) -> str | None:
        r = self.resources.get(resource)
        return r[1] if r else None

    def state_of(self, resource: str) -> str | None:
        s = self.states.get(resource)
        return s[0] if s else None

    def set_state(self, resource: str, state: str, reason: str) -> None:
        if resource in self.resources:
            self.states[resource] = (state, reason)
