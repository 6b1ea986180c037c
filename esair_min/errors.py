"""One error type per layer, each able to point at a place in a board file.

Library code raises these; only the CLI turns them into an exit status.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Mark:
    """A place in a file: 1-based line and column, as editors show them."""

    path: str
    line: int
    col: int

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


class ConfigError(EsairError):
    """A board file (or robot folder) that cannot become a valid model."""


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
