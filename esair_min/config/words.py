"""How error messages name keys and values: the few words every validator shares.

Light on purpose (no pydantic): the command line checks an option with them before it
has read any file.
"""

from __future__ import annotations

import difflib
import typing
from typing import Any


def kind_of(value: Any) -> str:
    """What a YAML value is, in the words of a YAML file (for error messages)."""
    if value is None:
        return "an empty value"
    if isinstance(value, bool):
        return "true/false"
    if isinstance(value, int):
        return "an integer"
    if isinstance(value, float):
        return "a number"
    if isinstance(value, str):
        return "text"
    if isinstance(value, (list, tuple)):
        return "a list"
    if isinstance(value, dict):
        return "a mapping"
    if isinstance(value, (bytes, bytearray)):
        return "binary data"
    return f"a {type(value).__name__}"


def did_you_mean(word: str, choices: typing.Iterable[str]) -> str:
    """`` (did you mean 'x'?)`` or an empty string."""
    close = difflib.get_close_matches(str(word), sorted(set(choices)), n=1, cutoff=0.6)
    return f" (did you mean '{close[0]}'?)" if close else ""


def quote(name: Any) -> str:
    """A key in quotes, escaped if it holds line breaks or other invisible characters."""
    text = str(name)
    return f"'{text}'" if text.isprintable() else repr(text)


def show(value: Any) -> str:
    """``text 'x'``, ``an integer 3``: a value as the YAML file has it."""
    kind = kind_of(value)
    if value is None:
        return kind
    text = repr(value) if isinstance(value, str) else str(value)
    return f"{kind} {text if len(text) <= 40 else text[:37] + '...'}"
