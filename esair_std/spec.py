"""The runtime's own view of one component to deploy, built from the deployment model
(esair_std.deploy) or from a control request, and sent as JSON to an agent process.

Keeping it here means the runtime reads the deployment model in one place only.
"""

from __future__ import annotations

import os
from typing import Any, Iterable, Mapping, Protocol, TypedDict, cast

from .level import Level
from .transport.codec import JSON, JSONObject

KINDS = ("behavior", "reaction", "resource")


class Spec:
    """One component to deploy. Immutable, compared by value. (A plain class rather than
    a frozen dataclass: an agent process builds one, and importing ``dataclasses`` costs
    1.2 MB of RSS in each; see esair_min's Mark.)"""

    __slots__ = ("kind", "name", "class_path", "options", "base_dir", "period", "has_period",
                 "uses", "restart_max", "restart_within", "allow", "resources", "enabled",
                 "where", "prepared")
    kind: str
    name: str
    class_path: str
    options: dict[str, object]       # the user's own (YAML, sent as JSON)
    base_dir: str | None
    period: float | None
    has_period: bool
    uses: dict[str, str]
    restart_max: int
    restart_within: float
    allow: dict[str, str]
    resources: tuple[str, ...]
    enabled: bool
    where: str
    prepared: JSONObject | None

    def __init__(self, kind: str, name: str, class_path: str,
                 options: Mapping[str, object] | None = None,
                 base_dir: str | None = None, period: float | None = None,
                 has_period: bool = False, uses: dict[str, str] | None = None,
                 restart_max: int = 0, restart_within: float = 0.0,
                 allow: dict[str, str] | None = None,
                 resources: tuple[str, ...] = (), enabled: bool = True, where: str = "",
                 prepared: JSONObject | None = None):
        values = dict(
            kind=kind,                           # behavior | reaction | resource
            name=name,
            class_path=class_path,               # module:Class
            options=({} if options is None else options if isinstance(options, dict)
                     else dict(options)),
            base_dir=base_dir,
            period=period,                       # None: the class's own
            has_period=has_period,               # the deployment set period (maybe to None)
            uses={} if uses is None else uses,   # behavior: resource (or glob) -> level name
            restart_max=restart_max,
            restart_within=restart_within,
            allow={} if allow is None else allow,  # resource: behavior (or glob) -> level
            resources=resources,                 # reaction: the resources it reaches
            enabled=enabled,                     # reaction
            where=where,                         # file:line:col of the entry, for messages
            # what the class's ``prepare`` made of the entry where the deployment was
            # checked (plain JSON: a driver's checked options and board, lean/compile.py)
            prepared=prepared)
        for key, value in values.items():
            object.__setattr__(self, key, value)

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError(f"cannot assign to field {name!r} of an immutable Spec")

    def __delattr__(self, name: str) -> None:
        raise AttributeError(f"cannot delete field {name!r} of an immutable Spec")

    __hash__ = None  # type: ignore[assignment]   # its dicts are not hashable

    def __eq__(self, other: object) -> bool:
        if type(other) is not Spec:
            return NotImplemented
        return all(getattr(self, k) == getattr(other, k) for k in self.__slots__)

    def __repr__(self) -> str:
        return "Spec(" + ", ".join(f"{k}={getattr(self, k)!r}" for k in self.__slots__) + ")"

    def to_json(self) -> JSONObject:
        d: JSONObject = {k: _copy(getattr(self, k)) for k in self.__slots__}
        d["resources"] = list(self.resources)
        return d

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> "Spec":   # to_json's fields, off the wire
        d = dict(d)
        d["resources"] = tuple(d.get("resources", ()))
        return cls(**d)


def _copy(value: JSON) -> JSON:
    """A deep copy of JSON-like data (dicts, lists, tuples), as dataclasses.asdict made."""
    if isinstance(value, dict):
        return {k: _copy(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return type(value)(_copy(v) for v in value)
    return value


def _where(entry: object) -> str:
    mark = getattr(entry, "mark", None)
    return str(mark) if mark is not None else ""


def _level_map(m: Mapping[str, Level | str] | None) -> dict[str, str]:
    return {str(k): Level.parse(v).name for k, v in dict(m or {}).items()}


class Entry(Protocol):
    """What :func:`specs_of` reads of every entry of a deployment (deploy/model.py's
    ComponentSpec); the rest (``allow``, ``uses``, ``period``...) it reads with getattr."""

    @property
    def class_path(self) -> str: ...
    @property
    def options(self) -> Mapping[str, Any] | None: ...     # the user's own options


class _Named(Entry, Protocol):
    @property
    def name(self) -> str: ...


def _entries(group: object) -> list[tuple[str, Entry]]:
    """(name, entry) pairs of a deployment group, in file order (dict or sequence)."""
    if isinstance(group, dict):
        return list(group.items())
    return [(e.name, e) for e in cast("Iterable[_Named]", group or ())]


def _period(entry: object) -> tuple[float | None, bool]:
    """An entry's ``period`` and whether the deployment set it (maybe to None)."""
    period = getattr(entry, "period", None)
    fields = getattr(entry, "model_fields_set", None)
    return period, ("period" in fields) if fields is not None else period is not None


class _Restart(TypedDict):
    restart_max: int
    restart_within: float


def _restart(entry: object) -> _Restart:
    """An entry's ``restart: {max, within}`` as Spec fields (none: no restart)."""
    restart = getattr(entry, "restart", None)
    if not restart:
        return {"restart_max": 0, "restart_within": 0.0}
    return {"restart_max": int(getattr(restart, "max", 0) or 0),
            "restart_within": float(getattr(restart, "within", 0) or 0)}


class Groups(Protocol):
    """What :func:`specs_of` reads of a loaded deployment (deploy/model.py)."""

    @property
    def resources(self) -> object: ...
    @property
    def behaviors(self) -> object: ...
    @property
    def reactions(self) -> object: ...


def specs_of(deployment: Groups) -> tuple[list[Spec], list[Spec], list[Spec]]:
    """The resources, behaviors and reactions of a loaded deployment, in file order."""
    base = getattr(deployment, "base_dir", None)

    def folder(e: object) -> str:
        return str(getattr(e, "base_dir", None) or base or os.getcwd())

    res, beh, rea = [], [], []
    for name, e in _entries(deployment.resources):
        res.append(Spec("resource", name, e.class_path, dict(e.options or {}), folder(e),
                        allow=_level_map(getattr(e, "allow", {})), where=_where(e),
                        **_restart(e)))
    for name, e in _entries(deployment.behaviors):
        period, has_period = _period(e)
        beh.append(Spec("behavior", name, e.class_path, dict(e.options or {}), folder(e),
                        period=period, has_period=has_period,
                        uses=_level_map(getattr(e, "uses", {})), where=_where(e),
                        **_restart(e)))
    for name, e in _entries(deployment.reactions):
        period, has_period = _period(e)
        rea.append(Spec("reaction", name, e.class_path, dict(e.options or {}), folder(e),
                        period=period, has_period=has_period,
                        resources=tuple(getattr(e, "resources", ()) or ()),
                        enabled=bool(getattr(e, "enabled", True)), where=_where(e)))
    return res, beh, rea
