"""The wire format: JSON, size-capped. Used by both modes so that data handed from one
component to another obeys the same rules (and is copied) whichever mode runs."""

from __future__ import annotations

import json
from typing import Mapping, Sequence, Union, cast

from ..errors import TransportError

#: Data on the wire: what ``json`` reads and writes (a request's body, a sample's value,
#: a command and its answer). Read-only containers (``Mapping``, ``Sequence``) so that a
#: ``list[str]`` or a ``dict[str, int]`` is JSON as it stands; a reader narrows with
#: ``isinstance`` (a decoded object is a ``dict``, an array a ``list``).
JSON = Union[Mapping[str, "JSON"], Sequence["JSON"], str, int, float, bool, None]
#: A JSON object: a request's or a reply's body.
JSONObject = dict[str, JSON]

MAX_BYTES = 256 * 1024


def encode(obj: JSON) -> bytes:
    try:
        data = json.dumps(obj, separators=(",", ":"), allow_nan=False).encode()
    except (TypeError, ValueError) as exc:
        raise TransportError(f"data is not JSON-serialisable: {exc}") from None
    if len(data) > MAX_BYTES:
        raise TransportError(f"message of {len(data)} bytes is over the {MAX_BYTES}-byte cap")
    return data


def decode(data: bytes) -> JSON:
    if len(data) > MAX_BYTES:
        raise TransportError(f"message of {len(data)} bytes is over the {MAX_BYTES}-byte cap")
    try:
        text = bytes(data).decode("utf-8")
    except UnicodeDecodeError:
        raise TransportError("message is not UTF-8 text") from None
    try:
        obj: JSON = json.loads(text)
    except ValueError as exc:
        raise TransportError(f"message is not JSON: {exc}") from None
    except RecursionError:
        raise TransportError("message is not JSON: nested too deeply") from None
    return obj


def copy(obj: object) -> JSON:
    """What the receiver gets: the value after one trip through the wire format (a
    value that is not JSON raises TransportError, as :func:`encode` does)."""
    return decode(encode(cast(JSON, obj)))


def decode_request(data: bytes) -> JSONObject:
    """A control or component request: a JSON object, else TransportError."""
    obj = decode(data)
    if not isinstance(obj, dict):
        raise TransportError("request is not a JSON object")
    return obj
