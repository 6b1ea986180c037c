"""Turn a pydantic ValidationError into one ConfigError that points into the YAML.

Pydantic reports a location such as ``('i2c', 'devices', 0, 'eeprom', 'size')``;
that path mixes data keys with union tags. We walk the loaded data along it, keep
the parts that exist, and take the mark of the deepest node found. Unknown keys and
bad choices get a did-you-mean hint from difflib.
"""

from __future__ import annotations

import difflib
import types
import typing
from typing import Any, Union

from pydantic import BaseModel, ValidationError

from .errors import ConfigError
from .yamlload import Document

_PATTERN_TEXT = {
    r"^[a-z][a-z0-9_]{0,23}$": "a lower-case name (a-z, 0-9, _; at most 24 characters, "
                               "starting with a letter)",
    r"^R[A-E][0-7]$": "a pin such as RB0 (RA0..RE7)",
    r"^[!-)+-~]{1,8}$": "a command prefix of 1 to 8 printable characters "
                        "(no space, no '*')",
}


def did_you_mean(word: str, choices: typing.Iterable[str]) -> str:
    """`` (did you mean 'x'?)`` or an empty string."""
    close = difflib.get_close_matches(str(word), sorted(set(choices)), n=1, cutoff=0.6)
    return f" (did you mean '{close[0]}'?)" if close else ""


def _unwrap(tp: Any) -> list[Any]:
    """The concrete types an annotation may hold (Optional/Union/Annotated removed)."""
    origin = typing.get_origin(tp)
    if origin is typing.Annotated:
        return _unwrap(typing.get_args(tp)[0])
    if origin in (Union, types.UnionType):
        out: list[Any] = []
        for arg in typing.get_args(tp):
            out.extend(_unwrap(arg))
        return out
    return [tp]


def _model_at(root: type[BaseModel], loc: tuple[Any, ...]) -> type[BaseModel] | None:
    """The model class whose keys live at ``loc`` (union tags in ``loc`` are followed)."""
    candidates: list[Any] = [root]
    for part in loc:
        nxt: list[Any] = []
        for tp in candidates:
            for t in _unwrap(tp):
                if isinstance(part, int) and typing.get_origin(t) is tuple:
                    nxt.extend(a for a in typing.get_args(t) if a is not Ellipsis)
                elif isinstance(t, type) and issubclass(t, BaseModel) and isinstance(part, str):
                    if part in t.model_fields:
                        nxt.append(t.model_fields[part].annotation)
                    elif _tag_of(t) == part:
                        nxt.append(t)
        candidates = nxt
    models = [t for tp in candidates for t in _unwrap(tp)
              if isinstance(t, type) and issubclass(t, BaseModel)]
    return models[0] if models else None


def _tag_of(model: type[BaseModel]) -> str | None:
    field = model.model_fields.get("kind")
    if field is None:
        return None
    args = typing.get_args(field.annotation)
    return args[0] if len(args) == 1 else None


def _data_path(data: Any, loc: tuple[Any, ...]) -> tuple[Any, ...]:
    """The longest prefix of ``loc`` (tags skipped) that exists in ``data``."""
    path: list[Any] = []
    cur = data
    for part in loc:
        if isinstance(cur, dict) and isinstance(part, str) and part in cur:
            cur = cur[part]
            path.append(part)
        elif isinstance(cur, list) and isinstance(part, int) and 0 <= part < len(cur):
            cur = cur[part]
            path.append(part)
    return tuple(path)


def _show(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _describe(err: dict[str, Any], key: str, model: type[BaseModel] | None) -> str:
    kind = err["type"]
    ctx = err.get("ctx") or {}
    value = err.get("input")
    if kind == "missing":
        return f"missing required key '{key}'"
    if kind == "extra_forbidden":
        allowed = list(model.model_fields) if model else []
        return f"unknown key '{key}'{did_you_mean(key, allowed)}"
    if kind in ("int_type", "int_parsing"):
        return f"'{key}' must be an integer, not {type(value).__name__} {_show(value)}"
    if kind in ("float_type", "float_parsing"):
        return f"'{key}' must be a number, not {type(value).__name__} {_show(value)}"
    if kind == "bool_type":
        return f"'{key}' must be true or false, not {_show(value)}"
    if kind == "string_type":
        return f"'{key}' must be a string, not {type(value).__name__} {_show(value)}"
    if kind in ("model_type", "model_attributes_type", "dict_type"):
        return f"'{key}' must be a mapping of keys, not {type(value).__name__} {_show(value)}"
    if kind in ("tuple_type", "list_type"):
        return f"'{key}' must be a list, not {type(value).__name__} {_show(value)}"
    if kind == "string_pattern_mismatch":
        pattern = ctx.get("pattern", "")
        return f"'{key}' must be {_PATTERN_TEXT.get(pattern, 'of the form ' + pattern)}, " \
               f"not {_show(value)}"
    if kind == "literal_error":
        expected = ctx.get("expected", "")
        options = [o.strip().strip("'") for o in expected.replace(" or ", ",").split(",")]
        options = [o for o in options if o]
        hint = did_you_mean(str(value), options) if isinstance(value, str) else ""
        return f"'{key}' must be one of {expected}, not {_show(value)}{hint}"
    if kind in ("union_tag_invalid", "union_tag_not_found"):
        return f"'kind' must be one of {ctx.get('expected_tags', '')}" + (
            f", not {_show(ctx.get('tag'))}" if "tag" in ctx else "")
    bounds = {
        "greater_than_equal": ("at least", "ge"), "less_than_equal": ("at most", "le"),
        "greater_than": ("greater than", "gt"), "less_than": ("less than", "lt"),
    }
    if kind in bounds:
        words, name = bounds[kind]
        return f"'{key}' must be {words} {ctx.get(name)}, not {_show(value)}"
    if kind in ("too_short", "too_long"):
        return f"'{key}' must have {'at least' if kind == 'too_short' else 'at most'} " \
               f"{ctx.get('min_length', ctx.get('max_length'))} items, " \
               f"not {ctx.get('actual_length')}"
    msg = err.get("msg", "invalid value")
    return f"'{key}': {msg[0].lower() + msg[1:]}"


def config_error(exc: ValidationError, doc: Document, root: type[BaseModel]) -> ConfigError:
    """The first error of ``exc`` as a ConfigError marked in ``doc``."""
    err = exc.errors(include_url=False)[0]
    loc = tuple(err["loc"])
    path = _data_path(doc.data, loc)
    data_keys = [p for p in loc if isinstance(p, str)]
    key = next((p for p in reversed(path) if isinstance(p, str)), "")
    if err["type"] == "missing":
        key = str(loc[-1])
        mark = doc.mark(path)
    elif err["type"] == "extra_forbidden":
        key = str(loc[-1])
        mark = doc.mark(path, key=True)
    else:
        mark = doc.mark(path)
        if not key and data_keys:
            key = data_keys[-1]
    model = _model_at(root, loc[:-1]) if err["type"] == "extra_forbidden" else None
    return ConfigError(_describe(err, key, model), mark)
