"""Marks for deployments given as a dict: the path of a value instead of a line.

A YAML deployment has line:column marks (esair_min's loader). A dict built in Python
has none, so every value is marked with its path, e.g. ``behaviors.follow.period``;
the same checks and messages then serve both.
"""

from __future__ import annotations

import re
from typing import Mapping

from esair_min.errors import Mark
from esair_min.config.yamlload import Document

from ..errors import DeployError

ROOT = "(top level)"
#: Deepest nesting walked in a dict (a YAML file is limited the same way).
MAX_DEPTH = 32
_PLAIN = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
#: Where a value is in a deployment: its keys and list indexes from the top.
Loc = tuple[str | int, ...]


class PathMark(Mark):
    """A place in a dict: shown as the dotted path of the value."""

    __slots__ = ("where",)
    _fields = Mark._fields + __slots__
    where: str

    def __init__(self, path: str, line: int, col: int, where: str = ROOT):
        super().__init__(path, line, col)
        object.__setattr__(self, "where", where)

    def __str__(self) -> str:
        return self.where


def where(loc: Loc) -> str:
    """``('behaviors', 'follow', 'uses', 'a.b')`` -> ``behaviors.follow.uses['a.b']``."""
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        elif _PLAIN.match(part):
            out += f".{part}" if out else part
        else:
            out += f"[{part!r}]"
    return out or ROOT


def dict_document(data: Mapping[str, object]) -> Document:
    """A Document over ``data`` whose marks are paths; refuses what YAML could not hold."""
    value_marks: dict[Loc, Mark] = {}
    key_marks: dict[Loc, Mark] = {}
    open_ids: set[int] = set()

    def walk(value: object, loc: Loc) -> object:
        mark = PathMark("<dict>", 0, 0, where(loc))
        value_marks[loc] = mark
        if isinstance(value, (dict, list, tuple)):
            if id(value) in open_ids:
                raise DeployError("this list or mapping contains itself (endless recursion)",
                                  mark)
            if len(loc) >= MAX_DEPTH:
                raise DeployError(f"nested more than {MAX_DEPTH} levels deep; a deployment "
                                  "needs far fewer", mark)
            open_ids.add(id(value))
            try:
                if isinstance(value, dict):
                    out = {}
                    for key, item in value.items():
                        if not isinstance(key, str):
                            raise DeployError(f"key {key!r} must be a name (text), not "
                                              f"{type(key).__name__}", mark)
                        key_marks[loc + (key,)] = PathMark("<dict>", 0, 0, where(loc + (key,)))
                        out[key] = walk(item, loc + (key,))
                    return out
                return [walk(item, loc + (i,)) for i, item in enumerate(value)]
            finally:
                open_ids.discard(id(value))
        return value

    root = data if isinstance(data, dict) else dict(data)
    return Document("<dict>", walk(root, ()), value_marks, key_marks)
