"""The STD deployment file: model, loader, class import (docs/std-deployment.md)."""

from ..errors import DeployError
from ..level import Level
from .bundled import bundled_examples, resolve_deployment
from .class_check import expected_bases, load_class, load_classes
from .loader import load_deployment, load_document
from .model import (DEFAULT_ENDPOINT, BehaviorSpec, ComponentSpec, Deployment,
                    ReactionSpec, ResourceSpec, RestartPolicy)
from .rules import notes, resource_entries
from .json_schema import deployment_schema
from .security import SecuritySpec

__all__ = [
    "DEFAULT_ENDPOINT", "BehaviorSpec", "ComponentSpec", "DeployError", "Deployment", "Level",
    "ReactionSpec", "ResourceSpec", "RestartPolicy", "SecuritySpec", "deployment_schema",
    "expected_bases", "load_class", "load_classes", "load_deployment", "load_document",
    "notes", "resource_entries", "bundled_examples", "resolve_deployment",
]
