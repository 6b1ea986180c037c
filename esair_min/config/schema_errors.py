"""Turn a pydantic ValidationError into one ConfigError that points into the YAML.

Pydantic reports a location such as ``('i2c', 'devices', 0, 'eeprom', 'size')``;
that path mixes data keys with union tags. We walk the loaded data along it, keep
the parts that exist, and take the mark of the deepest node found. Unknown keys and
bad choices get a did-you-mean hint from difflib.
"""

from __future__ import annotations

import types
import typing
from collections.abc import Callable
from typing import Any, Union

from pydantic import BaseModel, ValidationError
from pydantic_core import ErrorDetails

from esair_min.errors import ConfigError
from esair_min.config.yamlload import Document, kind_of
from esair_min.config.words import did_you_mean, quote

_PATTERN_TEXT = {
    r"^[a-z][a-z0-9_]{0,23}$": "a lower-case name (a-z, 0-9, _; at most 24 characters, "
                               "starting with a letter)",
    r"^R[A-E][0-7]$": "a pin such as RB0 (R, port A..E, bit 0..7)",
    r"^[!-)+-~]{1,8}$": "a command prefix of 1 to 8 printable characters "
                        "(no space, no '*')",
}


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
    models = _models_at(root, loc)
    return models[0] if models else None


def _models_at(root: type[BaseModel], loc: tuple[Any, ...]) -> list[type[BaseModel]]:
    """Every model class whose keys may live at ``loc`` (all members of a union)."""
    candidates: list[Any] = [root]
    for part in loc:
        nxt: list[Any] = []
        for tp in candidates:
            for t in _unwrap(tp):
                if isinstance(part, int) and typing.get_origin(t) is tuple:
                    nxt.extend(a for a in typing.get_args(t) if a is not Ellipsis)
                elif isinstance(part, str) and typing.get_origin(t) is dict:
                    nxt.append(typing.get_args(t)[1])     # a mapping of names to models
                elif isinstance(t, type) and issubclass(t, BaseModel) and isinstance(part, str):
                    if part in t.model_fields:
                        nxt.append(t.model_fields[part].annotation)
                    elif _tag_of(t) == part:
                        nxt.append(t)
        candidates = nxt
    return [t for tp in candidates for t in _unwrap(tp)
            if isinstance(t, type) and issubclass(t, BaseModel)]


def _tag_of(model: type[BaseModel]) -> str | None:
    field = model.model_fields.get("kind")
    if field is None:
        return None
    args = typing.get_args(field.annotation)
    return args[0] if len(args) == 1 else None


def _walk(data: Any, loc: tuple[Any, ...],
          passes: Callable[[Any, Any], bool]) -> tuple[Any, ...]:
    """The steps of ``loc`` that exist in ``data``, followed from its root; a step that
    does not exist is passed over where ``passes(node, step)`` says so, else the walk
    ends there."""
    path: list[Any] = []
    cur = data
    for part in loc:
        if (isinstance(cur, dict) and isinstance(part, str) and part in cur
                or isinstance(cur, list) and isinstance(part, int) and 0 <= part < len(cur)):
            cur = cur[part]  # type: ignore[index]  # a str into a dict, an int into a list
            path.append(part)
        elif not passes(cur, part):
            break
    return tuple(path)


def _data_path(data: Any, loc: tuple[Any, ...]) -> tuple[Any, ...]:
    """The longest prefix of ``loc`` (tags skipped) that exists in ``data``."""
    return _walk(data, loc, lambda node, step: True)


def _show(value: Any) -> str:
    """``value`` as a YAML writer would see it, e.g. ``text '20MHz'``, ``an empty value``."""
    kind = kind_of(value)
    if value is None:
        return kind
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (str, bytes)):
        text = repr(value)
    elif isinstance(value, (list, tuple, dict)):
        text = json_like(value)
    else:
        text = str(value)
    if not text.isprintable():
        text = text.encode("unicode_escape").decode("ascii")
    if len(text) > 40:
        text = text[:37] + "..."
    return f"{kind} {text}"


def json_like(value: Any) -> str:
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k if str(k).isprintable() else repr(k)}: {json_like(v)}"
                               for k, v in value.items()) + "}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(json_like(v) for v in value) + "]"
    if isinstance(value, bool):
        return "true" if value else "false"
    if value is None:
        return "null"
    return repr(value) if isinstance(value, str) else str(value)


def _plural(n: Any, word: str) -> str:
    return f"{n} {word}" if n == 1 else f"{n} {word}s"


def _yes_no_hint(value: Any) -> str:
    """YAML 1.1 reads unquoted yes/no/on/off as booleans: say so when it bites."""
    if isinstance(value, bool):
        return " (YAML reads unquoted yes/no/on/off/true/false as true/false: quote it)"
    return ""


def _number(key: str, value: Any) -> str:
    if "address" in key and isinstance(value, int) and not isinstance(value, bool):
        return f"{value} (0x{value:02X})"
    return str(value)


def _tags(root: type[BaseModel], loc: tuple[Any, ...]) -> list[str]:
    return [t for m in _models_at(root, loc) if (t := _tag_of(m)) is not None]


#: What a value of the wrong type should have been, by pydantic error type.
_MUST_BE = {
    "int_type": "an integer", "int_parsing": "an integer", "int_from_float": "an integer",
    "float_type": "a number", "float_parsing": "a number",
    "finite_number": "a finite number",
    "bool_type": "true or false",
    "string_type": "text",
    "model_type": "a mapping of keys", "model_attributes_type": "a mapping of keys",
    "dict_type": "a mapping of keys",
    "tuple_type": "a list", "list_type": "a list",
    "path_type": "a path (text)",
}


def _describe(err: ErrorDetails, key: str, model: type[BaseModel] | None,
              tags: list[str]) -> str:
    kind = err["type"]
    ctx = err.get("ctx") or {}
    value = err.get("input")
    if kind == "missing":
        return f"missing required key {quote(key)}"
    if kind == "extra_forbidden":
        allowed = list(model.model_fields) if model else []
        hint = did_you_mean(key, allowed)
        if not hint and allowed:
            hint = f" (allowed here: {', '.join(allowed)})"
        return f"unknown key {quote(key)}{hint}"
    if value is None and kind.endswith("_type"):
        return f"{quote(key)} has no value; give it one or remove the key"
    if kind in _MUST_BE:
        hint = _yes_no_hint(value) if kind == "string_type" else ""
        return f"{quote(key)} must be {_MUST_BE[kind]}, not {_show(value)}{hint}"
    if kind == "string_pattern_mismatch":
        pattern = ctx.get("pattern", "")
        return f"{quote(key)} must be {_PATTERN_TEXT.get(pattern, 'of the form ' + pattern)}, " \
               f"not {_show(value)}"
    if kind == "literal_error":
        expected = ctx.get("expected", "")
        options = [o.strip().strip("'") for o in expected.replace(" or ", ",").split(",")]
        options = [o for o in options if o]
        hint = did_you_mean(str(value), options) if isinstance(value, str) else ""
        return f"{quote(key)} must be {'one of ' if len(options) > 1 else ''}{expected}, " \
               f"not {_show(value)}{hint or _yes_no_hint(value)}"
    if kind in ("union_tag_invalid", "union_tag_not_found"):
        choices = " or ".join(f"'{t}'" for t in tags) or ctx.get("expected_tags", "")
        if kind == "union_tag_not_found" or "tag" not in ctx:
            return f"missing required key 'kind' ({choices})"
        tag = ctx.get("tag")
        return f"'kind' must be {choices}, not {_show(tag)}{did_you_mean(str(tag), tags)}"
    bounds = {
        "greater_than_equal": ("at least", "ge"), "less_than_equal": ("at most", "le"),
        "greater_than": ("greater than", "gt"), "less_than": ("less than", "lt"),
    }
    if kind in bounds:
        words, name = bounds[kind]
        return f"{quote(key)} must be {words} {_number(key, ctx.get(name))}, " \
               f"not {_number(key, value)}"
    if kind in ("too_short", "too_long"):
        n = ctx.get("min_length", ctx.get("max_length"))
        actual = len(value) if isinstance(value, (list, tuple, dict, str)) else \
            ctx.get("actual_length")
        return f"{quote(key)} must have {'at least' if kind == 'too_short' else 'at most'} " \
               f"{_plural(n, 'item')}, not {actual}"
    if kind == "value_error" and ctx.get("error") is not None:
        # A model's own check (a model_validator's ValueError): its words, not pydantic's.
        return f"{quote(key)}: {' '.join(str(ctx['error']).split())}"
    msg = err.get("msg", "invalid value")
    return f"{quote(key)}: {msg[0].lower() + msg[1:]}"


def _label(path: tuple[Any, ...], loc: tuple[Any, ...]) -> str:
    """The name of the node in messages: its key, with list positions, e.g. ``angles[3]``."""
    parts = list(path)
    while parts and not isinstance(parts[-1], str):
        parts.pop()
    if not parts:
        names = [p for p in loc if isinstance(p, str)]
        return names[-1] if names else ""
    return parts[-1] + "".join(f"[{i}]" for i in path[len(parts):])


def pick_error(errors: list[ErrorDetails], data: Any) -> ErrorDetails:
    """The error to report: an unknown key first (a misspelt key causes the other
    errors), else pydantic's first error, made as precise as its siblings allow (a
    union such as ``speed: 3`` or ``speed: [..]`` reports the branch that matches)."""
    for err in errors:
        if err["type"] == "extra_forbidden":
            return err
    first = errors[0]
    base = _data_path(data, tuple(first["loc"]))
    best, depth = first, len(base)
    for err in errors[1:]:
        path = _data_path(data, tuple(err["loc"]))
        if path[:len(base)] == base and len(path) > depth:
            best, depth = err, len(path)
    return best


def config_error(exc: ValidationError, doc: Document, root: type[BaseModel]) -> ConfigError:
    """The most useful error of ``exc`` as a ConfigError marked in ``doc``."""
    return _config_error(pick_error(exc.errors(include_url=False), doc.data), doc, root)


def _node_of(data: Any, loc: tuple[Any, ...]) -> tuple[Any, ...]:
    """The part of ``loc`` before its first step that is not in ``data`` (an untagged
    union's branch, or a missing key): the node the error is about. A tagged union's
    tag (the node's own ``kind``) is passed over: pydantic reports that branch only."""
    return _walk(data, loc, lambda node, step: isinstance(node, dict) and step == node.get("kind"))


def schema_errors(exc: ValidationError, doc: Document, root: type[BaseModel]) -> list[ConfigError]:
    """Every error of ``exc``, one per node, each a ConfigError marked in ``doc``.

    pydantic reports each branch of a union that failed; the errors about one node
    (the part of their location that exists in the data) are one error, the most
    useful of them (:func:`pick_error`). A key missing from a mapping that also has an
    unknown key is not reported: the misspelt key is the error."""
    groups: dict[tuple[Any, ...], list[ErrorDetails]] = {}
    unknown_in: set[tuple[Any, ...]] = set()
    for err in exc.errors(include_url=False):
        loc = tuple(err["loc"])
        node = _node_of(doc.data, loc)
        if err["type"] == "extra_forbidden":
            unknown_in.add(node[:-1])
        elif err["type"] == "missing" and node == loc[:-1]:
            node = loc                  # each missing key of a mapping is its own error
        groups.setdefault(node, []).append(err)
    out = []
    for node, errs in groups.items():
        if all(e["type"] == "missing" for e in errs) and node[:-1] in unknown_in:
            continue
        out.append(_config_error(pick_error(errs, doc.data), doc, root))
    return out


def _config_error(err: ErrorDetails, doc: Document, root: type[BaseModel]) -> ConfigError:
    loc = tuple(err["loc"])
    path = _data_path(doc.data, loc)
    tags: list[str] = []
    if err["type"] in ("missing", "extra_forbidden"):
        key = str(loc[-1])
        mark = doc.mark(path, key=err["type"] == "extra_forbidden")
    elif err["type"] in ("union_tag_invalid", "union_tag_not_found"):
        key = "kind"
        tags = _tags(root, loc)
        mark = doc.mark(path + ("kind",) if err["type"] == "union_tag_invalid" else path)
    else:
        key = _label(path, loc)
        mark = doc.mark(path)
    model = _model_at(root, loc[:-1]) if err["type"] == "extra_forbidden" else None
    return ConfigError(_describe(err, key, model, tags), mark)
