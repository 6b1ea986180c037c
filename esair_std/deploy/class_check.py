"""Import every class of a deployment, checking each kind's base class and, when the
class declares them (``Options``), the entry's options against its schema.

The importer itself is :func:`esair_std.classes.load_class` (one for the deployment
check, the runtime and agents); it is re-exported here.
"""

from __future__ import annotations

from ..classes import load_class
from .class_options import check_options, options_model
from .model import Deployment

__all__ = ["expected_bases", "load_class", "load_classes"]


def load_classes(dep: Deployment) -> dict[str, type]:
    """Import every class of ``dep`` (name -> class), checking each kind's base class
    when esair_std defines it, and the entry's options against the class's ``Options``
    (each error at its option's line); the first failure raises."""
    out = {}
    for kind, spec in dep.components():
        cls = out[spec.name] = load_class(spec, expect=expected_bases(kind))
        model = options_model(cls)
        if model is not None:
            check_options(model, dict(spec.options), spec.options_doc)
    return out


_BASES = {"resource": ("Sensor", "Actuator", "Driver"), "behavior": ("Behavior",),
          "reaction": ("Reaction",)}


def expected_bases(kind: str) -> tuple[type, ...] | None:
    """The esair_std base classes a ``kind`` of component must derive from."""
    import esair_std

    bases = tuple(getattr(esair_std, n) for n in _BASES[kind] if hasattr(esair_std, n))
    return bases or None
