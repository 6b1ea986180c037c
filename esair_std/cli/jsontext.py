"""A command-line value that is "JSON or text" (``put DATA``, ``send VALUE``, ``configure
VALUE``, ``-o KEY=VALUE``): JSON when it parses, else the text itself. A value that starts
like JSON (``{``, ``[`` or ``"``) but does not parse (NaN and Infinity are not JSON) is
a usage error pointing at the column, never a string sent in its place: a JSON typo would
otherwise reach the robot as text. Text that starts so is sent on purpose with the
command's ``--text`` (or, for an option, written as a JSON string)."""

from __future__ import annotations

import json
from typing import NoReturn

import click

from ..transport.codec import JSON

#: The first characters of a value that was meant as JSON (after leading blanks).
LIKE_JSON = ("{", "[", '"')

class _NotJsonNumber(ValueError):
    """NaN, Infinity, -Infinity: Python's json reads them, JSON has no such numbers."""


def _no_constant(name: str) -> NoReturn:
    raise _NotJsonNumber(name)


#: What the error says to do: for DATA/VALUE arguments (the command has --text).
USE_TEXT = "to send it as text use --text"


def json_or_text(text: str, what: str, hint: str = USE_TEXT) -> JSON:
    """``text`` as JSON (1, 2.5, true, {"a": 1}, "s") if it parses, else the text itself;
    raises click.UsageError when it starts like JSON and does not parse (``what`` names
    the value: ``DATA``, ``VALUE``, ``-o gain``)."""
    try:
        obj: JSON = json.loads(text, parse_constant=_no_constant)
        return obj
    except _NotJsonNumber as exc:
        # sent as is it would put non-standard JSON on the wire: text, or an error as below
        if not text.lstrip().startswith(LIKE_JSON):
            return text
        raise click.UsageError(f"{what} is not JSON at column {text.find(str(exc)) + 1}: "
                               f"{exc} is not a JSON number; {hint}") from None
    except json.JSONDecodeError as exc:
        if not text.lstrip().startswith(LIKE_JSON):
            return text
        where = (f"column {exc.colno}" if exc.lineno == 1
                 else f"line {exc.lineno} column {exc.colno}")
        msg = exc.msg.removesuffix(" starting at")        # json's "Unterminated string ..."
        raise click.UsageError(f"{what} is not JSON at {where}: {msg}; {hint}") from None
    except RecursionError:
        raise click.UsageError(f"{what} is JSON nested too deeply to be read") from None


def option_value(key: str, text: str) -> JSON:
    """The VALUE of ``-o KEY=VALUE``: as :func:`json_or_text`; text that starts like JSON
    is given as a JSON string."""
    return json_or_text(text, f"-o {key}",
                        f"to give it as text, write it as a JSON string (-o '{key}=\"...\"')")
