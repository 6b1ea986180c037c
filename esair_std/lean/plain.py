"""A checked deployment as plain data: what the runtime reads of one, nothing more.

:class:`PlainDeployment` stands where :class:`esair_std.deploy.model.Deployment`
stands for :class:`esair_std.runtime.Runtime`: its robot, mode, endpoint and folder,
and each component as a :class:`~esair_std.spec.Spec` (with what its class's
``prepare`` made of the entry: a driver's checked options and board). Built from the
JSON :mod:`esair_std.deploy.compile` writes; a plain class (no dataclasses, no pydantic).
"""

from __future__ import annotations

from typing import Any, Mapping

from ..spec import Spec
from ..transport.codec import JSONObject

#: The JSON's layout; another one (an older cache) is not read.
FORMAT = 1


class PlainDeployment:
    """A deployment checked elsewhere (see the module docstring)."""

    __slots__ = ("robot", "mode", "endpoint", "base_dir", "source", "specs")
    #: a deployment with a security section is never made plain (lean/run.py)
    security = None

    def __init__(self, robot: str, mode: str, endpoint: str, base_dir: str,
                 source: str | None, specs: list[Spec]):
        self.robot = robot
        self.mode = mode
        self.endpoint = endpoint
        self.base_dir = base_dir
        self.source = source
        self.specs = specs            # resources, then reactions, then behaviors' order kept

    def split(self) -> tuple[list[Spec], list[Spec], list[Spec]]:
        """Resources, behaviors, reactions (spec.specs_of's order)."""
        return ([s for s in self.specs if s.kind == "resource"],
                [s for s in self.specs if s.kind == "behavior"],
                [s for s in self.specs if s.kind == "reaction"])

    def to_json(self) -> JSONObject:
        return {"format": FORMAT, "robot": self.robot, "mode": self.mode,
                "endpoint": self.endpoint, "base_dir": self.base_dir, "source": self.source,
                "specs": [s.to_json() for s in self.specs]}

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "PlainDeployment":
        """The JSON of :meth:`to_json`; ValueError when it is not that (a cache of
        another layout, a damaged file)."""
        try:
            if d.get("format") != FORMAT:
                raise ValueError(f"format {d.get('format')!r}, not {FORMAT}")
            return cls(str(d["robot"]), str(d["mode"]), str(d["endpoint"]),
                       str(d["base_dir"]), d.get("source"),
                       [Spec.from_json(s) for s in d["specs"]])
        except (KeyError, TypeError, AttributeError) as exc:
            raise ValueError(f"not a plain deployment: {exc!r}") from None
