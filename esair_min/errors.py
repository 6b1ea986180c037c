"""One error type per layer, each able to point at a place in a board file.

Library code raises these; only the CLI turns them into an exit status.
"""

from __future__ import annotations

from pathlib import Path
from typing import Iterable


class Mark:
    """A place in a file: 1-based line and column, as editors show them. Immutable,
    compared and hashed by value. (A plain class rather than a frozen dataclass: every
    ESAIR STD agent process imports this module, and importing ``dataclasses`` pulls in
    ``inspect``, ``ast``, ``dis`` and ``tokenize``: 1.2 MB of RSS per process.)"""

    __slots__ = ("path", "line", "col")
    _fields: tuple[str, ...] = __slots__
    path: str
    line: int
    col: int

    def __init__(self, path: str, line: int, col: int):
        object.__setattr__(self, "path", path)
        object.__setattr__(self, "line", line)
        object.__setattr__(self, "col", col)

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError(f"cannot assign to field {name!r} of an immutable "
                             f"{type(self).__name__}")

    def __delattr__(self, name: str) -> None:
        raise AttributeError(f"cannot delete field {name!r} of an immutable "
                             f"{type(self).__name__}")

    def _key(self) -> tuple[object, ...]:
        return tuple(getattr(self, name) for name in self._fields)

    def __eq__(self, other: object) -> bool:
        if type(other) is not type(self):
            return NotImplemented
        return self._key() == other._key()

    def __hash__(self) -> int:
        return hash(self._key())

    def __repr__(self) -> str:
        shown = ", ".join(f"{name}={getattr(self, name)!r}" for name in self._fields)
        return f"{type(self).__name__}({shown})"

    def __reduce__(self) -> tuple[type[Mark], tuple[object, ...]]:
        return (type(self), self._key())

    def __str__(self) -> str:
        if self.line <= 0:                 # a path as a whole (it may not exist)
            return self.path
        return f"{self.path}:{self.line}:{self.col}"


class EsairError(Exception):
    """Base of every error ESAIR MIN raises on purpose."""

    def __init__(self, message: str, mark: Mark | None = None):
        super().__init__(message)
        self.message = message
        self.mark = mark

    def __str__(self) -> str:
        if self.mark is None:
            return self.message
        return f"{self.mark}: {self.message}"

    def lines(self) -> list[str]:
        """The error as the CLI prints it, one ``error: `` line each."""
        return [str(self)]


class ConfigError(EsairError):
    """A board file (or robot folder) that cannot become a valid model."""

    def each(self) -> tuple[ConfigError, ...]:
        """Every single error this one stands for (itself)."""
        return (self,)


#: ``esair check`` prints at most this many errors of a robot, then ``and N more``: a
#: screenful, and what a user fixes before checking again (docs/board-format.md).
SHOWN_ERRORS = 20


def _place(err: ConfigError) -> tuple[str, int, int, str]:
    m = err.mark
    return (m.path, m.line, m.col, err.message) if m is not None else ("", 0, 0, err.message)


class ConfigErrors(ConfigError):
    """Every error found in a robot's board files, sorted by file, line and column
    (each once). Its own message and mark are the first one's; ``str()`` is every error
    on its own line, at most :data:`SHOWN_ERRORS` and then ``and N more errors``."""

    def __init__(self, errors: Iterable[ConfigError]):
        unique = {(str(e.mark), e.message): e for e in errors for e in e.each()}
        self.errors = tuple(sorted(unique.values(), key=_place))
        if not self.errors:
            raise ValueError("ConfigErrors of no error")
        super().__init__(self.errors[0].message, self.errors[0].mark)

    def __reduce__(self) -> tuple[type[ConfigErrors], tuple[tuple[ConfigError, ...]]]:
        return (type(self), (self.errors,))

    def each(self) -> tuple[ConfigError, ...]:
        return self.errors

    def lines(self) -> list[str]:
        shown = [str(e) for e in self.errors[:SHOWN_ERRORS]]
        if len(self.errors) > SHOWN_ERRORS:
            shown.append(f"and {len(self.errors) - SHOWN_ERRORS} more errors "
                         f"({len(self.errors)} in all)")
        return shown

    def __str__(self) -> str:
        return "\n".join(self.lines())


def config_errors(errors: Iterable[ConfigError]) -> ConfigError | None:
    """One error to raise for ``errors``: None for none, the error itself for one,
    else :class:`ConfigErrors`."""
    found = [e for err in errors for e in err.each()]
    if not found:
        return None
    return found[0] if len(found) == 1 else ConfigErrors(found)


class ImageError(EsairError):
    """An EEPROM motion image that is malformed or does not fit."""


class ProtocolError(EsairError):
    """A command line or protocol object that is not valid."""


class GenerateError(EsairError):
    """The firmware generator could not produce its output."""


def file_mark(path: Path | str) -> Mark:
    """The mark of a whole file (its first line)."""
    return Mark(str(path), 1, 1)


def path_mark(path: Path | str) -> Mark:
    """The mark of a path without a place in it (a file or folder that is missing):
    printed as the path alone, with no line:col."""
    return Mark(str(path), 0, 0)
