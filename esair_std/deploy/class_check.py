"""Import every class of a deployment, checking each kind's base class.

The importer itself is :func:`esair_std.classes.load_class` (one for the deployment
check, the runtime and agents); it is re-exported here.
"""

from __future__ import annotations

from ..classes import load_class
from .model import Deployment

__all__ = ["expected_bases", "load_class", "load_classes"]


def load_classes(dep: Deployment) -> dict[str, type]:
    """Import every class of ``dep`` (name -> class), checking each kind's base class
    when esair_std defines it; the first failure raises."""
    return {spec.name: load_class(spec, expect=expected_bases(kind))
            for kind, spec in dep.components()}


_BASES = {"resource": ("Sensor", "Actuator", "Driver"), "behavior": ("Behavior",),
          "reaction": ("Reaction",)}


def expected_bases(kind: str) -> tuple[type, ...] | None:
    """The esair_std base classes a ``kind`` of component must derive from."""
    import esair_std

    bases = tuple(getattr(esair_std, n) for n in _BASES[kind] if hasattr(esair_std, n))
    return bases or None
