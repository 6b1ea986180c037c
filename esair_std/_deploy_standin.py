"""TEMPORARY stand-in for esair_std.deploy (built by another helper); deleted when it lands.
Minimal: no marks, no schema, few checks."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from .errors import DeployError
from .level import Level


@dataclass(frozen=True)
class Restart:
    max: int = 0
    within: float = 0.0


@dataclass(frozen=True)
class Entry:
    name: str
    class_path: str
    options: dict = field(default_factory=dict)
    allow: dict = field(default_factory=dict)
    uses: dict = field(default_factory=dict)
    period: float | None = None
    restart: Restart | None = None
    resources: tuple = ()
    enabled: bool = True
    base_dir: str | None = None
    mark: Any = None
    model_fields_set: frozenset = frozenset()


@dataclass(frozen=True)
class Deployment:
    robot: str
    mode: str
    endpoint: str
    resources: tuple
    behaviors: tuple
    reactions: tuple
    base_dir: str


_KNOWN = {"class", "allow", "uses", "period", "restart", "resources", "enabled"}


def _entry(name: str, raw: dict, base: str) -> Entry:
    if not isinstance(raw, dict) or "class" not in raw:
        raise DeployError(f"{name}: needs a class")
    opts = {k: v for k, v in raw.items() if k not in _KNOWN}
    r = raw.get("restart")
    return Entry(name, raw["class"], opts,
                 {k: Level.parse(v) for k, v in (raw.get("allow") or {}).items()},
                 {k: Level.parse(v) for k, v in (raw.get("uses") or {}).items()},
                 raw.get("period"), Restart(**r) if r else None,
                 tuple(raw.get("resources") or ()), bool(raw.get("enabled", True)), base,
                 None, frozenset(k for k in ("period",) if k in raw))


def load_deployment(src: Any) -> Deployment:
    if isinstance(src, dict):
        raw, base = src, os.getcwd()
    else:
        p = Path(src)
        raw, base = yaml.safe_load(p.read_text()), str(p.resolve().parent)
    g = lambda k: [_entry(n, v, base) for n, v in (raw.get(k) or {}).items()]  # noqa: E731
    return Deployment(raw.get("robot", "robot"), raw.get("mode", "thread"),
                      raw.get("endpoint", "tcp/127.0.0.1:7447"),
                      tuple(g("resources")), tuple(g("behaviors")), tuple(g("reactions")), base)
