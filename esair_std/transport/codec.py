"""The wire format: JSON, size-capped. Used by both modes so that data handed from one
component to another obeys the same rules (and is copied) whichever mode runs."""

from __future__ import annotations

import json
from typing import Any, Union

from ..errors import TransportError

#: Data on the wire: what ``json`` reads and writes (a request's body, a sample's value,
#: a command and its answer). Decoded data is typed ``Any`` where the code reads fields
#: it has just checked; what is sent is typed ``JSON``.
JSON = Union[dict[str, "JSON"], list["JSON"], str, int, float, bool, None]
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


def decode(data: bytes) -> Any:
    if len(data) > MAX_BYTES:
        raise TransportError(f"message of {len(data)} bytes is over the {MAX_BYTES}-byte cap")
    try:
        text = bytes(data).decode("utf-8")
    except UnicodeDecodeError:
        raise TransportError("message is not UTF-8 text") from None
    try:
        return json.loads(text)
    except ValueError as exc:
        raise TransportError(f"message is not JSON: {exc}") from None
    except RecursionError:
        raise TransportError("message is not JSON: nested too deeply") from None


def copy(obj: Any) -> Any:
    """What the receiver gets: the value after one trip through the wire format."""
    return decode(encode(obj))


def decode_request(data: bytes) -> dict[str, Any]:
    """A control or component request: a JSON object, else TransportError."""
    obj = decode(data)
    if not isinstance(obj, dict):
        raise TransportError("request is not a JSON object")
    return obj
