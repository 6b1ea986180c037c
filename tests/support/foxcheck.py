"""Check Foxglove messages against Foxglove's own definitions: a protobuf message is
decoded with the FileDescriptorSet its channel carries (the ``protobuf`` package) into
the JSON shape of Foxglove's JSON Schemas (timestamps ``{sec, nsec}``, bytes base64,
every field present), which is validated against the JSON Schema of that type from
the npm package @foxglove/schemas 2.1.0 (MIT; tests/fixtures/foxglove_schemas.json);
a JSON message is validated against the JSON schema its channel carries."""

from __future__ import annotations

import base64
import json
from functools import lru_cache
from pathlib import Path
from typing import Any

import jsonschema
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

FOXGLOVE = json.loads((Path(__file__).resolve().parents[1] / "fixtures"
                       / "foxglove_schemas.json").read_text())


@lru_cache(maxsize=None)
def _message_class(name: str, data: bytes) -> Any:
    fds = descriptor_pb2.FileDescriptorSet.FromString(data)
    pool = descriptor_pool.DescriptorPool()
    for f in fds.file:
        pool.Add(f)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(name))


def _as_json(msg: Any) -> dict:
    """Every field of ``msg`` (defaults too), as Foxglove's JSON Schemas spell them."""
    out: dict[str, Any] = {}
    for field in msg.DESCRIPTOR.fields:
        v = getattr(msg, field.name)
        out[field.name] = _value(field, v)
    return out


def _value(field: Any, v: Any) -> Any:
    repeated = getattr(field, "is_repeated", None)
    if repeated is None:
        repeated = field.label == field.LABEL_REPEATED
    if repeated:
        return [_one(field, x) for x in v]
    return _one(field, v)


def _one(field: Any, v: Any) -> Any:
    if field.type == field.TYPE_MESSAGE:
        if field.message_type.full_name in ("google.protobuf.Timestamp", "google.protobuf.Duration"):
            return {"sec": v.seconds, "nsec": v.nanos}
        return _as_json(v)
    if field.type == field.TYPE_BYTES:
        return base64.b64encode(v).decode()
    return v


@lru_cache(maxsize=None)
def _validator(schema_text: str | bytes) -> Any:
    """A validator of the JSON Schema ``schema_text``, the schema itself checked once
    (``jsonschema.validate`` checks it again for every message)."""
    schema = json.loads(schema_text)
    cls = jsonschema.validators.validator_for(schema)
    cls.check_schema(schema)
    return cls(schema)


def decode(schema: Any, data: bytes) -> dict:
    """An MCAP/Foxglove-protocol message of ``schema`` (name, encoding, data) as a dict,
    validated against Foxglove's (or its channel's) JSON Schema."""
    if schema.encoding == "protobuf":
        msg = _message_class(schema.name, bytes(schema.data)).FromString(data)
        obj = _as_json(msg)
        _validator(json.dumps(FOXGLOVE[schema.name])).validate(obj)
        return obj
    assert schema.encoding == "jsonschema", schema.encoding
    obj = json.loads(data)
    text = schema.data if isinstance(schema.data, str) else bytes(schema.data)
    _validator(text).validate(obj)
    return obj
