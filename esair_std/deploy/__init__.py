"""The STD deployment file: model, loader, class import (docs/std-deployment.md).

The names below are imported when first used (PEP 562): importing one light module of
this package (``bundled``, ``overrides``) must not load the loader's pydantic into a
robot side that was handed its deployment checked (esair_std/lean/).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from ..errors import DeployError
from ..level import Level

if TYPE_CHECKING:  # pragma: no cover
    from .bundled import bundled_examples, resolve_deployment
    from .class_check import expected_bases, load_class, load_classes
    from .loader import load_deployment, load_document
    from .model import (DEFAULT_ENDPOINT, BehaviorSpec, ComponentSpec, Deployment,
                        ReactionSpec, ResourceSpec, RestartPolicy)
    from .rules import notes, resource_entries
    from .json_schema import deployment_schema
    from .security import SecuritySpec

_FROM = {
    "bundled_examples": "bundled", "resolve_deployment": "bundled",
    "expected_bases": "class_check", "load_class": "class_check",
    "load_classes": "class_check", "load_deployment": "loader", "load_document": "loader",
    "DEFAULT_ENDPOINT": "model", "BehaviorSpec": "model", "ComponentSpec": "model",
    "Deployment": "model", "ReactionSpec": "model", "ResourceSpec": "model",
    "RestartPolicy": "model", "notes": "rules", "resource_entries": "rules",
    "deployment_schema": "json_schema", "SecuritySpec": "security",
}


def __getattr__(name: str) -> object:
    module = _FROM.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{module}"), name)


__all__ = [
    "DEFAULT_ENDPOINT", "BehaviorSpec", "ComponentSpec", "DeployError", "Deployment", "Level",
    "ReactionSpec", "ResourceSpec", "RestartPolicy", "SecuritySpec", "deployment_schema",
    "expected_bases", "load_class", "load_classes", "load_deployment", "load_document",
    "notes", "resource_entries", "bundled_examples", "resolve_deployment",
]
