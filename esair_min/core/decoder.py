"""The command decoder: line assembly, checksum, matching and arguments (docs/protocol.md).

Two pieces, both without I/O:

- :class:`LineAssembler` takes one byte at a time into a fixed 40-byte buffer and, at a
  line end, yields the line or the code of a line-level error (E12, E02, E13);
- :class:`CommandTable` turns a line into a table row and its arguments, or an error
  code, checking in the order of the contract: checksum (E06/E11), matching (E01/E03),
  then (after the caller's E07 check) the arguments (E03).

Execution (limits, overflow, motions, the bus) belongs to :mod:`esair_min.core.central`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Sequence, Union

from esair_min.model.board import Command
from esair_min.core.protocol import (ANGLE_CODE_FIRST, ANGLE_CODE_LAST, ANGLE_STEP, CHECKSUM_CHARS,
                       MAX_LINE, MAX_SPEED, Code)

CR = 0x0D
LF = 0x0A
_HEX = b"0123456789ABCDEF"
_STAR = 0x2A
_DOT = 0x2E
_A = 0x61
_Z = 0x7A
_UNPRINTABLE = re.compile(rb"[^\x20-\x7e]")
#: A whole line and its CR LF, short enough for the buffer (:meth:`LineAssembler.feed_run`).
_WHOLE_LINE = re.compile(rb"[\x20-\x7e]{1,%d}\r\n" % MAX_LINE).fullmatch

Args = tuple
#: What a finished line gives: a code, or the line's bytes (terminator removed).
LineResult = Union[Code, bytes]


class LineAssembler:
    """Byte-at-a-time line assembly into a fixed buffer of :data:`MAX_LINE` bytes."""

    __slots__ = ("buf", "length", "overflow", "bad", "overrun", "after_cr")

    def __init__(self) -> None:
        self.buf = bytearray(MAX_LINE)   # never grows
        self.reset()

    def reset(self) -> None:
        self.length = 0
        self.overflow = False      # a byte past the 40th was dropped
        self.bad = False           # a byte outside 0x20..0x7E was received
        self.overrun = False       # bytes were lost inside this line (it is damaged)
        self.after_cr = False      # the previous byte was CR (a following LF is swallowed)

    def note_overrun(self) -> None:
        """Bytes were lost at this point of the stream (between the byte fed last and
        the next one): the line being received is damaged from its start through the
        gap to the next line end, and is answered E12 there, once, even if no byte of
        it arrived. A CR before the gap no longer pairs with an LF after it."""
        self.overrun = True
        self.after_cr = False

    def feed(self, b: int) -> LineResult | None:
        """One received byte; at a non-empty line end, the line or its error code."""
        if 0x20 <= b <= 0x7E:
            n = self.length
            if n < MAX_LINE:
                self.buf[n] = b
                self.length = n + 1
            else:
                self.overflow = True
            self.after_cr = False
            return None
        if b in (LF, CR):
            if b == LF and self.after_cr:
                self.after_cr = False
                return None
            return self._end(b == CR)
        self.bad = True
        n = self.length
        if n < MAX_LINE:
            self.buf[n] = b & 0xFF
            self.length = n + 1
        else:
            self.overflow = True
        self.after_cr = False
        return None

    def feed_run(self, data: bytes) -> list[LineResult]:
        """:meth:`feed` of each byte of ``data`` in turn: what the line ends gave, in
        order. Stretches of printable bytes are stored in one go."""
        if (not self.length and not (self.overflow or self.bad or self.overrun or self.after_cr)
                and _WHOLE_LINE(data)):
            # one whole line from a clean start (a host's command): the line, and the
            # assembler left as its bytes leave it (clean: the LF after the CR swallowed)
            n = len(data) - 2
            self.buf[:n] = data[:n]
            return [bytes(data[:n])]
        out: list[LineResult] = []
        pos, end = 0, len(data)
        find = _UNPRINTABLE.search
        while pos < end:
            m = find(data, pos)
            stop = m.start() if m is not None else end
            if stop > pos:                  # printable bytes: what feed() does to each
                n, k = self.length, stop - pos
                if n + k <= MAX_LINE:
                    self.buf[n:n + k] = data[pos:stop]
                    self.length = n + k
                else:
                    self.buf[n:MAX_LINE] = data[pos:pos + MAX_LINE - n]
                    self.length = MAX_LINE
                    self.overflow = True
                self.after_cr = False
                pos = stop
            if pos < end:
                r = self.feed(data[pos])
                if r is not None:
                    out.append(r)
                pos += 1
        return out

    def _end(self, cr: bool) -> LineResult | None:
        n = self.length
        if self.overrun:
            result: LineResult | None = Code.OVERRUN
        elif self.overflow:
            result = Code.TOO_LONG
        elif n == 0:
            result = None
        elif self.bad:
            result = Code.BAD_CHARACTER
        else:
            result = bytes(self.buf[:n])
        self.length = 0
        self.overflow = self.bad = self.overrun = False
        self.after_cr = cr
        return result


@dataclass(frozen=True)
class Row:
    """One command of the table, prepared for matching."""

    command: Command
    action: str
    prefix: bytes
    length: int            # characters of a matching line, checksum excluded
    motion: int | None     # fixed play: the motion number
    variable: bool = False  # lines of any length from ``length`` on match (image_write)


@dataclass(frozen=True)
class Decoded:
    row: Row
    args: Args

    @property
    def action(self) -> str:
        return self.row.action


class CommandTable:
    """A robot's command table: checksum, matching and argument parsing."""

    def __init__(self, commands: Sequence[Command], servos: int,
                 motion_numbers: dict[str, int], require_checksum: bool = False):
        self.servos = servos
        self.require_checksum = require_checksum
        self.rows = tuple(Row(c, c.action, c.prefix.encode("ascii"), c.length(servos),
                              motion_numbers.get(c.motion) if c.motion else None,
                              c.variable)
                          for c in commands)

    # -- checks in contract order ------------------------------------------------------
    def strip_checksum(self, line: bytes) -> Code | bytes:
        """The line without its ``*HH`` suffix, or E06/E11."""
        n = len(line)
        if n >= CHECKSUM_CHARS and line[n - 3] == _STAR:
            x = 0
            for i in range(n - 3):
                x ^= line[i]
            if line[n - 2] != _HEX[x >> 4] or line[n - 1] != _HEX[x & 15]:
                return Code.BAD_CHECKSUM
            return line[:n - 3]
        if self.require_checksum:
            return Code.CHECKSUM_REQUIRED
        return line

    def match(self, body: bytes) -> Code | Row:
        """The row whose prefix starts ``body`` and whose length it has; E01/E03."""
        prefixed = False
        n = len(body)
        for row in self.rows:
            if body.startswith(row.prefix):
                if row.length == n or (row.variable and n > row.length):
                    return row
                prefixed = True
        return Code.BAD_ARGUMENT if prefixed else Code.UNKNOWN

    def parse(self, row: Row, body: bytes) -> Args | None:
        """The arguments of a matched line, or None (E03)."""
        a = body[len(row.prefix):]
        action = row.action
        if action == "motor":
            m = a[0] - _A
            s = a[1] - _A
            if not 0 <= m < self.servos or not 0 <= s <= MAX_SPEED:
                return None
            angle = _digits(a, 2, 3)
            return None if angle < 0 else (m, s, angle)
        if action == "play":
            if row.motion is not None:
                return (row.motion,)
            number = _digits(a, 0, 2)
            return None if number < 0 else (number,)
        if action == "speeds":
            speeds = []
            for i in range(0, 3 * self.servos, 3):
                v = _digits(a, i, 3)
                if not 0 <= v <= MAX_SPEED:
                    return None
                speeds.append(v)
            return tuple(speeds)
        if action == "angles":
            angles: list[int | None] = []
            for c in a:
                if c == _DOT:
                    angles.append(None)
                elif ANGLE_CODE_FIRST <= c <= ANGLE_CODE_LAST:
                    angles.append(ANGLE_STEP * (c - ANGLE_CODE_FIRST))
                else:
                    return None
            return tuple(angles)
        if action == "image_write":
            # address, data bytes, checksum byte: an even count of hex digits
            if len(a) % 2:
                return None
            raw = _hex_bytes(a)
            return None if raw is None else (raw,)
        if action == "image_read":
            raw = _hex_bytes(a)
            return None if raw is None else (raw,)
        if action == "hold":
            held = _digits(a, 0, 1)
            return None if held not in (0, 1) else (held,)
        return ()   # stand, version, sensors, stop, image_commit, i2c_scan: no arguments

    def decode(self, line: bytes) -> Code | Decoded:
        """Checksum, match and arguments of one line (no busy check): for clients/tests."""
        body = self.strip_checksum(line)
        if isinstance(body, Code):
            return body
        row = self.match(body)
        if isinstance(row, Code):
            return row
        args = self.parse(row, body)
        return Code.BAD_ARGUMENT if args is None else Decoded(row, args)


_HEX_VALUE = {c: i for i, c in enumerate(_HEX)}


def _hex_bytes(a: bytes) -> bytes | None:
    """Pairs of upper-case hex digits as bytes, or None if a character is not one."""
    out = bytearray()
    for i in range(0, len(a) - 1, 2):
        hi, lo = _HEX_VALUE.get(a[i]), _HEX_VALUE.get(a[i + 1])
        if hi is None or lo is None:
            return None
        out.append(hi << 4 | lo)
    return bytes(out)


def _digits(a: bytes, start: int, count: int) -> int:
    """The decimal number of the ``count`` characters of ``a`` from ``start``, or -1 if
    one is not a digit (a matched line always has them all: its length is the row's)."""
    digits = a[start:start + count]
    return int(digits) if len(digits) == count and digits.isdigit() else -1   # ASCII 0-9
