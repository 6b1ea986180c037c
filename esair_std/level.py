"""Usage levels of a resource: ``read`` < ``command`` < ``configure``."""

from __future__ import annotations

from enum import IntEnum
from fnmatch import fnmatchcase
from typing import Mapping


class Level(IntEnum):
    read = 1
    command = 2
    configure = 3

    @classmethod
    def parse(cls, text: "str | Level") -> "Level":
        if isinstance(text, Level):
            return text
        try:
            return cls[str(text)]
        except KeyError:
            raise ValueError(
                f"unknown level {text!r} (expected read, command or configure)") from None

    def __str__(self) -> str:
        return self.name


def best_match(table: Mapping[str, "Level | str"], name: str) -> Level | None:
    """The highest level of the entries whose key (a name or an fnmatch glob) matches."""
    best: Level | None = None
    for pattern, level in table.items():
        if pattern == name or fnmatchcase(name, pattern):
            lv = Level.parse(level)
            if best is None or lv > best:
                best = lv
    return best
