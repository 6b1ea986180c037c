"""Reading stimulus scripts (docs/trace-format.md, "Stimulus scripts"): lines, the
characters a line may hold, words, numbers and ``rx`` texts.

The host C ports read scripts by the same rules (``firmware_templates/common/
host_script.j2``), with the same error messages, word for word:

- a script is bytes; a line ends at LF, and a CR at its very end belongs to the line
  end (CRLF); lines may be of any length;
- a line must be UTF-8 text without control characters (0x00-0x1F but tab, 0x7F):
  a raw CR, VT, FF or FS anywhere is an error that says to write it as ``\\xHH`` in an
  ``rx`` text;
- blanks are spaces and tabs; a line whose first non-blank character is ``#`` is a
  comment; ``rx`` takes the rest of its line after ``rx `` verbatim (``#`` is data),
  other lines end at a ``#``;
- numbers are ASCII digits only (no sign, no ``_``, no ``0x``), at most 9 (decimal)
  or 8 (hex), within each command's range.

Errors are :class:`LineError` (message and column); the harness adds the file and the
line number.
"""

from __future__ import annotations

import re
from typing import Iterator

from esair_min.errors import ProtocolError

_CONTROL = re.compile(rb"[\x00-\x08\x0a-\x1f\x7f]")
_BLANKS = re.compile(r"[ \t]+")
_DECIMAL = re.compile(r"[0-9]{1,9}")
_HEX = re.compile(r"[0-9A-Fa-f]{1,8}")
BLANK = " \t"


class LineError(ProtocolError):
    """A script line that cannot be run: the message and the column (1-based, in
    characters) it points at."""

    def __init__(self, message: str, column: int = 1):
        super().__init__(message)
        self.column = column


def script_lines(data: bytes) -> Iterator[tuple[int, bytes]]:
    """(number, bytes) of each line, line ends removed (LF, and a CR right before it
    or at the end of the data)."""
    pieces = data.split(b"\n")
    if pieces[-1] == b"":
        pieces.pop()
    for number, raw in enumerate(pieces, start=1):
        yield number, raw[:-1] if raw.endswith(b"\r") else raw


def line_text(raw: bytes) -> str:
    """The text of a line: UTF-8 with no control character but tab (LineError at the
    first offending byte otherwise)."""
    ctl = _CONTROL.search(raw)
    try:
        text = raw[:ctl.start() if ctl else len(raw)].decode("utf-8")
    except UnicodeDecodeError as exc:
        column = len(raw[:exc.start].decode("utf-8")) + 1
        raise LineError(f"not UTF-8 text (byte 0x{raw[exc.start]:02X})", column) from None
    if ctl is not None:
        code = raw[ctl.start()]
        raise LineError(f"control character 0x{code:02X} (in an rx text write it as "
                        f"\\x{code:02X})", len(text) + 1)
    return text


def words(text: str) -> list[str]:
    """The blank-separated words of a command (comment already removed)."""
    text = text.strip(BLANK)
    return _BLANKS.split(text) if text else []


def decimal(word: str, what: str, top: int) -> int:
    """A decimal number from 0 to ``top``."""
    if _DECIMAL.fullmatch(word) and int(word) <= top:
        return int(word)
    raise LineError(f"{what} '{word}' is not a decimal number from 0 to {top}")


def hexadecimal(word: str, what: str, top: int) -> int:
    """A hex number from 0 to ``top``."""
    if _HEX.fullmatch(word) and int(word, 16) <= top:
        return int(word, 16)
    raise LineError(f"{what} '{word}' is not a hex number from 0 to {top:X}")


def unescape(text: str, column: int = 1) -> bytes:
    r"""The bytes of an ``rx`` text: printable ASCII as it is, C escapes ``\r`` ``\n``
    ``\xHH`` ``\\``. ``column``: where the text starts in its line (for errors)."""
    out = bytearray()
    i = 0
    n = len(text)
    while i < n:
        c = text[i]
        if c != "\\":
            if not " " <= c <= "~":
                raise LineError(f"character U+{ord(c):04X} in rx text (write its bytes as "
                                f"\\xHH)", column + i)
            out.append(ord(c))
            i += 1
            continue
        e = text[i + 1:i + 2]
        if e == "r":
            out.append(0x0D)
        elif e == "n":
            out.append(0x0A)
        elif e == "\\":
            out.append(0x5C)
        elif e == "x" and re.fullmatch(r"[0-9A-Fa-f]{2}", text[i + 2:i + 4]):
            out.append(int(text[i + 2:i + 4], 16))
            i += 2
        else:
            raise LineError(r"unknown escape (use \r \n \xHH \\)", column + i)
        i += 2
    return bytes(out)
