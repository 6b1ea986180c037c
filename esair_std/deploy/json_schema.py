"""The JSON Schema of the deployment file, from the model's own definitions."""

from __future__ import annotations

from ..transport.codec import JSONObject
from .model import Deployment


def deployment_schema() -> JSONObject:
    """JSON Schema (draft 2020-12) of a deployment file, for editors and validators."""
    doc = Deployment.model_json_schema(by_alias=True)
    doc["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    doc["title"] = "ESAIR STD deployment file"
    return doc
