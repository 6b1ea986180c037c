"""The serial line as the robot's decoder saw it: each line with its own reply.

Every non-empty line the decoder completes gets exactly one reply, in order
(docs/protocol.md); ``!`` notices answer no line. So each reply belongs to the oldest
line still waiting for one, and a notice is a row of its own. The line is recorded as
the decoder received it, not as the PC sent it: when bytes were lost in a receive
overrun, the row shows the damaged line (``⋯`` where bytes are missing) next to the
``E12`` that answers it.
"""

from __future__ import annotations

import re
from collections import deque
from dataclasses import dataclass

GAP_MARK = "⋯"          # where bytes were lost in the line
MAX_KEEP = 80            # characters of a line kept for display
_LINE_END = re.compile(rb"[\r\n]")


@dataclass
class Row:
    """One row: a line and its reply (``kind='line'``) or a notice (``kind='notice'``)."""

    kind: str
    text: str
    reply: str | None = None


def _printable(data: bytes | bytearray) -> str:
    return "".join(chr(b) if 0x20 <= b < 0x7F else f"\\x{b:02x}" for b in data)


class Transcript:
    """Rows of the serial line, the newest last (at most ``keep``)."""

    def __init__(self, keep: int = 40, gap_flag: int = 0x100):
        self.rows: deque[Row] = deque(maxlen=keep)
        self._waiting: deque[Row] = deque(maxlen=keep)
        self._early: deque[str] = deque(maxlen=keep)
        self._buf = bytearray()
        self._text: list[str] = []     # pieces of the current line (gap marks between)
        self._gap_flag = gap_flag

    # -- what the decoder receives ---------------------------------------------------
    def rx(self, data: bytes) -> None:
        """Bytes fed to the decoder back to back (no gap flags: a run of whole bytes)."""
        parts = _LINE_END.split(data)
        self._keep(parts[0])
        for part in parts[1:]:
            self._end()
            self._keep(part)

    def _keep(self, part: bytes) -> None:
        room = MAX_KEEP - len(self._buf)
        if part and room > 0:
            self._buf += part[:room]

    def rx_ring(self, got: list[int]) -> None:
        """Bytes taken from the receive ring in one go (gap flags included)."""
        if not got:
            return
        if max(got) <= 0xFF:
            self.rx(bytes(got))
            return
        for b in got:
            self.rx_byte(b)

    def rx_byte(self, b: int) -> None:
        """One byte fed to the decoder (with the ring's gap flag, if bytes were lost
        right before it)."""
        if b & self._gap_flag:
            self._gap()
            b &= 0xFF
        if b == 13 or b == 10:
            self._end()
        elif len(self._buf) < MAX_KEEP:
            self._buf.append(b)

    def _gap(self) -> None:
        self._text.append(_printable(self._buf))
        self._text.append(GAP_MARK)
        self._buf.clear()

    def _end(self) -> None:
        if not self._buf and not self._text:
            return                               # an empty line: no reply comes
        text = "".join(self._text) + _printable(self._buf)
        self._buf.clear()
        self._text.clear()
        row = Row("line", text)
        self.rows.append(row)
        if self._early:                          # its reply was recorded first
            row.reply = self._early.popleft()
        else:
            self._waiting.append(row)

    # -- what the board sends ---------------------------------------------------------
    def board_line(self, line: str) -> None:
        if line.startswith("!"):
            self.rows.append(Row("notice", line))
        elif self._waiting:
            self._waiting.popleft().reply = line
        else:       # its line is still being recorded (the ring's bytes go in batches)
            self._early.append(line)
