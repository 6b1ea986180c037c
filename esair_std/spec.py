"""The runtime's own view of one component to deploy, built from the deployment model
(esair_std.deploy) or from a control request, and sent as JSON to an agent process.

Keeping it here means the runtime reads the deployment model in one place only.
"""

from __future__ import annotations

import os
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from .level import Level

KINDS = ("behavior", "reaction", "resource")


@dataclass(frozen=True)
class Spec:
    kind: str                                   # behavior | reaction | resource
    name: str
    class_path: str                             # module:Class
    options: dict = field(default_factory=dict)
    base_dir: str | None = None
    period: float | None = None                 # None: the class's own
    has_period: bool = False                    # the deployment set period (maybe to None)
    uses: dict = field(default_factory=dict)    # behavior: resource (or glob) -> level name
    restart_max: int = 0
    restart_within: float = 0.0
    allow: dict = field(default_factory=dict)   # resource: behavior (or glob) -> level name
    resources: tuple = ()                       # reaction: the resources it reaches
    enabled: bool = True                        # reaction
    where: str = ""                             # file:line:col of the entry, for messages

    def to_json(self) -> dict:
        d = asdict(self)
        d["resources"] = list(self.resources)
        return d

    @classmethod
    def from_json(cls, d: dict) -> "Spec":
        d = dict(d)
        d["resources"] = tuple(d.get("resources", ()))
        return cls(**d)

    def uses_level(self, resource: str) -> Level | None:
        from .level import best_match
        return best_match(self.uses, resource)


def _where(entry: Any) -> str:
    mark = getattr(entry, "mark", None)
    return str(mark) if mark is not None else ""


def _level_map(m: Any) -> dict:
    return {str(k): Level.parse(v).name for k, v in dict(m or {}).items()}


def _entries(group: Any):
    """(name, entry) pairs of a deployment group, in file order (dict or sequence)."""
    if isinstance(group, dict):
        return list(group.items())
    return [(e.name, e) for e in (group or ())]


def _period(entry: Any) -> tuple[float | None, bool]:
    """An entry's ``period`` and whether the deployment set it (maybe to None)."""
    period = getattr(entry, "period", None)
    fields = getattr(entry, "model_fields_set", None)
    return period, ("period" in fields) if fields is not None else period is not None


def specs_of(deployment: Any) -> tuple[list[Spec], list[Spec], list[Spec]]:
    """The resources, behaviors and reactions of a loaded deployment, in file order."""
    base = getattr(deployment, "base_dir", None)

    def folder(e: Any) -> str:
        return str(getattr(e, "base_dir", None) or base or os.getcwd())

    res, beh, rea = [], [], []
    for name, e in _entries(deployment.resources):
        res.append(Spec("resource", name, e.class_path, dict(e.options or {}), folder(e),
                        allow=_level_map(getattr(e, "allow", {})), where=_where(e)))
    for name, e in _entries(deployment.behaviors):
        restart = getattr(e, "restart", None)
        period, has_period = _period(e)
        beh.append(Spec("behavior", name, e.class_path, dict(e.options or {}), folder(e),
                        period=period, has_period=has_period,
                        uses=_level_map(getattr(e, "uses", {})),
                        restart_max=int(getattr(restart, "max", 0) or 0) if restart else 0,
                        restart_within=float(getattr(restart, "within", 0) or 0) if restart else 0.0,
                        where=_where(e)))
    for name, e in _entries(deployment.reactions):
        period, has_period = _period(e)
        rea.append(Spec("reaction", name, e.class_path, dict(e.options or {}), folder(e),
                        period=period, has_period=has_period,
                        resources=tuple(getattr(e, "resources", ()) or ()),
                        enabled=bool(getattr(e, "enabled", True)), where=_where(e)))
    return res, beh, rea


def load(deployment: Any):
    """A Deployment from a path, a dict or an already loaded Deployment."""
    if isinstance(deployment, (str, Path, dict)):
        from .deploy import load_deployment
        return load_deployment(deployment)
    return deployment
