"""The JSON Schema of the deployment file, from the model's own definitions."""

from __future__ import annotations

from typing import Any

from .model import Deployment


def deployment_schema() -> dict[str, Any]:
    """JSON Schema (draft 2020-12) of a deployment file, for editors and validators."""
    doc = Deployment.model_json_schema(by_alias=True)
    doc["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    doc["title"] = "ESAIR STD deployment file"
    return doc
