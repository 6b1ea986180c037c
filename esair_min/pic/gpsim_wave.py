"""Reading what gpsim recorded: pin waveforms, I2C bus transactions, register logs.

gpsim's ``FileRecorder`` module writes one ``cycle value`` line per edge (plus an
analog ``cycle volts`` line we drop); ``log w REG`` writes each instruction that
wrote a logged register with its cycle. These functions turn both into data: edges,
decoded I2C transactions (a logic-analyser view of SCL/SDA, independent of the
firmware), and register writes. Stdlib only.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

from esair_min.pic.toolchain import ToolchainError


def read_edges(path: str | Path) -> list[tuple[int, int]]:
    """``(cycle, level)`` for every level change a FileRecorder wrote (digital lines only).

    The recorder's first line is the level at cycle 0; repeated levels are dropped.
    """
    edges: list[tuple[int, int]] = []
    for line in Path(path).read_text().splitlines():
        parts = line.split()
        if len(parts) != 2 or parts[1] not in ("0", "1"):
            continue
        level = int(parts[1])
        if edges and edges[-1][1] == level:
            continue
        edges.append((int(parts[0]), level))
    return edges


@dataclass
class I2cSegment:
    """From a (repeated) START: the address byte as on the wire (7-bit address << 1 |
    R/W), whether it was ACKed, then each further byte with its ACK (0 on SDA)."""

    addr_byte: int
    addr_ack: bool
    data: list[tuple[int, bool]] = field(default_factory=list)

    @property
    def address(self) -> int:
        return self.addr_byte >> 1

    @property
    def reading(self) -> bool:
        return bool(self.addr_byte & 1)

    def payload(self) -> bytes:
        return bytes(b for b, _ in self.data)


@dataclass
class I2cTransfer:
    """One START..STOP on the bus, split into segments at repeated STARTs."""

    start: int                                   # cycle of the START
    segments: list[I2cSegment] = field(default_factory=list)
    stop: int | None = None                      # cycle of the STOP
    last_byte_end: int = 0                       # cycle of the last byte's ACK clock
    cut: bool = False                            # a held line ended it (no STOP)

    def trace_line(self) -> str:
        """The transfer as a docs/trace-format.md ``W`` or ``R`` line.

        A write whose address was not ACKed shows the bytes the master still sent
        (the MSSP master usually stops at once, so none). A transfer cut by a held
        line is a failed one: ``W aa <bytes on the wire> NACK`` or ``R aa <...> ? NACK``."""
        segs = self.segments
        if not segs:
            raise ToolchainError(f"I2C transfer at cycle {self.start} has no address byte")
        first = segs[0]
        if self.cut:
            kind = "R" if any(s.reading for s in segs) else "W"
            count = " ?" if kind == "R" else ""
            return f"{kind} {first.address:02X} {first.payload().hex().upper()}{count} NACK"
        if len(segs) == 1 and not first.reading:
            ok = first.addr_ack and all(a for _, a in first.data)
            return f"W {first.address:02X} {first.payload().hex().upper()} {'ACK' if ok else 'NACK'}"
        if len(segs) == 1 and first.reading:
            wdata, read = b"", first
        elif len(segs) == 2 and not first.reading and segs[1].reading:
            wdata, read = first.payload(), segs[1]
            if not first.addr_ack:
                return f"R {first.address:02X} {wdata.hex().upper()} ? NACK"
        else:
            raise ToolchainError(f"I2C transfer at cycle {self.start}: "
                                 f"{len(segs)} segments, not a write, read or write+read")
        got = read.payload().hex().upper() if read.addr_ack else "NACK"
        return f"R {read.address:02X} {wdata.hex().upper()} {len(read.data)} {got}"


def decode_i2c(scl: list[tuple[int, int]], sda: list[tuple[int, int]],
               holds: tuple[tuple[int, int], ...] = ()) -> list[I2cTransfer]:
    """Transfers seen on SCL/SDA edge lists (open-drain bus, idle high).

    START = SDA falls while SCL is high; STOP = SDA rises while SCL is high; a bit is
    SDA sampled at each SCL rising edge; 9 bits make a byte and its ACK (0 = ACK).
    The MSSP changes SDA only while SCL is low, so no two edges share a cycle; if
    they did, SCL would be taken first.

    ``holds``: (first, last) cycles, inclusive, while something outside the master
    held a line low (the harness's ``fault bus``/``fault sda``). Edges inside are not
    decoded (the master's attempts cannot form a START); a transfer still open when a
    hold begins is ``cut`` there, and the next START after it begins a new transfer.
    """
    events = sorted([(c, 0, v) for c, v in scl] + [(c, 1, v) for c, v in sda])
    level = [1, 1]                 # SCL, SDA
    out: list[I2cTransfer] = []
    cur: I2cTransfer | None = None
    bits: list[int] = []
    for cycle, pin, v in events:
        if level[pin] == v:
            continue
        level[pin] = v
        if any(a <= cycle <= b for a, b in holds):
            if cur is not None and cur.stop is None:
                cur.cut = True
            cur, bits = None, []
            continue
        if pin == 1 and level[0] == 1:           # SDA moved while SCL high
            if v == 0:                           # START or repeated START
                if cur is None or cur.stop is not None:
                    cur = I2cTransfer(start=cycle)
                    out.append(cur)
                cur.segments.append(I2cSegment(-1, False))
                bits = []
            elif cur is not None:                # STOP (for now: see below)
                cur.stop = cycle
                bits = []
        elif pin == 0 and cur is not None:
            if v == 0 and cur.stop is not None:
                # gpsim 0.31's MSSP drives a repeated START as SDA low, SCL high,
                # SDA high (a STOP on the wire), SCL low, SCL high, SDA low. After a
                # real STOP, SCL stays high until the next START; so a falling SCL
                # after a STOP means it was the first half of a repeated START.
                cur.stop = None
            elif v == 1 and cur.stop is None:    # SCL rising: sample SDA
                bits.append(level[1])
                if len(bits) == 9:
                    value, acked = int("".join(map(str, bits[:8])), 2), bits[8] == 0
                    seg = cur.segments[-1]
                    if seg.addr_byte < 0:
                        seg.addr_byte, seg.addr_ack = value, acked
                    else:
                        seg.data.append((value, acked))
                    cur.last_byte_end = cycle
                    bits = []
    for t in out:
        t.segments = [s for s in t.segments if s.addr_byte >= 0]
    return out


_INSN_RE = re.compile(r"^(?:\d+:\s*)?0x([0-9A-Fa-f]+) \S+ 0x[0-9A-Fa-f]+ ")
_WROTE_RE = re.compile(r"^(?:\d+:)?\s+Wrote: 0x([0-9A-Fa-f]+) to (\w+)\(")
_READ_RE = re.compile(r"^(?:\d+:)?\s+Read: 0x([0-9A-Fa-f]+) from (\w+)\(")


def read_register_log(path: str | Path, names: set[str],
                      reads: bool = False) -> list[tuple[int, str, int]]:
    """``(cycle, register, value)`` for each write to one of ``names`` in a gpsim log
    (``log on FILE`` + ``log w _REG``); names as gpsim spells them (``_TXREG``). With
    ``reads``: each read instead (``log r _REG``). gpsim prefixes some lines with the
    C source line (``994:``)."""
    out: list[tuple[int, str, int]] = []
    cycle = 0
    access = _READ_RE if reads else _WROTE_RE
    for line in Path(path).read_text(errors="replace").splitlines():
        m = _INSN_RE.match(line)
        if m:
            cycle = int(m.group(1), 16)
            continue
        w = access.match(line)
        if w and w.group(2) in names:
            out.append((cycle, w.group(2), int(w.group(1), 16)))
    return out


def transfer_kinds(transfers: list[I2cTransfer]) -> dict[tuple[int, int | None], list[int]]:
    """START..STOP durations (cycles) of the acknowledged transfers, by kind: (bytes
    written after the address byte, bytes read or None for a plain write)."""
    kinds: dict[tuple[int, int | None], list[int]] = {}
    for t in transfers:
        segs = t.segments
        if t.stop is None or not segs or not all(s.addr_ack for s in segs):
            continue
        if len(segs) == 1 and not segs[0].reading:
            key: tuple[int, int | None] = (len(segs[0].data), None)
        elif len(segs) == 2 and not segs[0].reading and segs[1].reading:
            key = (len(segs[0].data), len(segs[1].data))
        else:
            continue
        kinds.setdefault(key, []).append(t.stop - t.start)
    return kinds
