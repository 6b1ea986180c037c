"""The runtime's own view of one component to deploy, built from the deployment model
(esair_std.deploy) or from a control request, and sent as JSON to an agent process.

Keeping it here means the runtime reads the deployment model in one place only.
"""

from __future__ import annotations

import importlib
import os
import sys
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from .errors import ComponentError
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


def import_class(class_path: str, base_dir: str | None, where: str = "") -> type:
    """``module:Class`` imported from ``base_dir`` first, then sys.path."""
    at = f"{where}: " if where else ""
    module_name, sep, cls_name = class_path.partition(":")
    if not sep or not module_name or not cls_name:
        raise ComponentError(f"{at}class {class_path!r} is not of the form module:Class")
    added = False
    if base_dir and base_dir not in sys.path:
        sys.path.insert(0, base_dir)
        added = True
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        raise ComponentError(f"{at}cannot import module {module_name!r} ({exc})") from None
    except Exception as exc:  # noqa: BLE001 - user module failing on import
        raise ComponentError(
            f"{at}module {module_name!r} failed on import: {type(exc).__name__}: {exc}"
        ) from None
    finally:
        if added:
            sys.path.remove(base_dir)
    obj = module
    for part in cls_name.split("."):
        obj = getattr(obj, part, None)
        if obj is None:
            raise ComponentError(f"{at}module {module_name!r} has no class {cls_name!r}")
    if not isinstance(obj, type):
        raise ComponentError(f"{at}{class_path!r} is not a class")
    return obj


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


def specs_of(deployment: Any) -> tuple[list[Spec], list[Spec], list[Spec]]:
    """The resources, behaviors and reactions of a loaded deployment, in file order."""
    base = getattr(deployment, "base_dir", None)
    res, beh, rea = [], [], []
    for name, e in _entries(deployment.resources):
        res.append(Spec("resource", name, e.class_path, dict(e.options or {}),
                        str(getattr(e, "base_dir", None) or base or os.getcwd()),
                        allow=_level_map(getattr(e, "allow", {})), where=_where(e)))
    for name, e in _entries(deployment.behaviors):
        restart = getattr(e, "restart", None)
        period = getattr(e, "period", None)
        fields = getattr(e, "model_fields_set", None)
        has_period = ("period" in fields) if fields is not None else period is not None
        beh.append(Spec("behavior", name, e.class_path, dict(e.options or {}),
                        str(getattr(e, "base_dir", None) or base or os.getcwd()),
                        period=period, has_period=has_period,
                        uses=_level_map(getattr(e, "uses", {})),
                        restart_max=int(getattr(restart, "max", 0) or 0) if restart else 0,
                        restart_within=float(getattr(restart, "within", 0) or 0) if restart else 0.0,
                        where=_where(e)))
    for name, e in _entries(deployment.reactions):
        period = getattr(e, "period", None)
        fields = getattr(e, "model_fields_set", None)
        has_period = ("period" in fields) if fields is not None else period is not None
        rea.append(Spec("reaction", name, e.class_path, dict(e.options or {}),
                        str(getattr(e, "base_dir", None) or base or os.getcwd()),
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
