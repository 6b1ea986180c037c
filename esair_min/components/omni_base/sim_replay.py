"""The Python core of an omni base's central board fed a simulator run's events (PIC in
gpsim, ATmega328P in simavr), for the differential tests: each byte at the cycle the
firmware took it from its USART, each tick at its timer's period end, each change of a
flow sensor at its cycle, in cycle order. A line end closer than ``margin`` cycles to a
tick is refused: which comes first would be a matter of a few cycles, not of the logic.
:func:`compare` names the first difference per part of two :class:`Run` s.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from esair_min.components.omni_base.core import StarfishCore
from esair_min.components.optical_flow.core import REG_DELTA_X, REG_DELTA_Y, REG_SQUAL
from esair_min.errors import ProtocolError


@dataclass
class Run:
    """What a firmware or the Python core did, as comparable lists."""

    replies: list[str] = field(default_factory=list)       # "TX text"
    writes: list[str] = field(default_factory=list)        # "W 30 00C800... ACK"
    flow: list[list[str]] = field(default_factory=list)    # per sensor: "RR DD"


@dataclass(frozen=True)
class FlowChange:
    """From ``cycle`` on, flow sensor ``sensor``'s SDIO is pulled to ``floor`` (0/1), or
    the sensor answers again with ``motion`` (dx, dy, squal) as its next deltas and SQUAL."""

    cycle: int
    sensor: int
    floor: int | None = None
    motion: tuple[int, int, int] | None = None


class FlowModel:
    """An ADNS-2610-class sensor as the simulators model it: Delta_X/Delta_Y hold what
    was set until read (then 0), SQUAL what was set, other registers 0; a pulled SDIO
    (``floor``) reads 0x00 / 0xFF whatever the register. Logs every read as ``RR DD``."""

    def __init__(self, log: list[str]):
        self.floor: int | None = None
        self.regs = {REG_DELTA_X: 0, REG_DELTA_Y: 0, REG_SQUAL: 0}
        self.log = log
        self._reg = 0

    def change(self, c: FlowChange) -> None:
        if c.motion is not None:
            dx, dy, q = c.motion
            self.regs.update({REG_DELTA_X: dx & 0xFF, REG_DELTA_Y: dy & 0xFF, REG_SQUAL: q & 0xFF})
            self.floor = None               # the sensor answers again
        else:
            self.floor = c.floor

    def address(self, reg: int, t_ns: int) -> None:
        self._reg = reg & 0x7F

    def data(self, t_ns: int) -> int:
        if self.floor is not None:
            v = 0xFF if self.floor else 0x00
        else:
            v = self.regs.get(self._reg, 0)
            if self._reg in (REG_DELTA_X, REG_DELTA_Y):
                self.regs[self._reg] = 0
        self.log.append(f"{self._reg:02X} {v:02X}")
        return v


def reply_lines(data: bytes) -> list[str]:
    out = []
    while b"\r\n" in data:
        line, _, data = data.partition(b"\r\n")
        out.append("TX " + line.decode("latin-1"))
    return out


def replay(robot: Any, rx: list[tuple[int, int]], ticks: list[int], changes: list[FlowChange],
           margin: int) -> Run:
    """The Python core fed ``rx`` ``(cycle, byte)``, ``ticks`` (cycles) and ``changes``."""
    drive = robot.board("drive").i2c.address
    run = Run(flow=[[] for _ in robot.central.flow_sensors])
    sensors = [FlowModel(log) for log in run.flow]

    def write(addr: int, data: bytes) -> bool:
        run.writes.append(f"W {addr:02X} {data.hex().upper()} ACK")
        return addr == drive

    core = StarfishCore(robot, write, sensors)
    events: list[tuple[int, int, int]] = [(c, 1, b) for c, b in rx]
    events += [(c, 0, -1) for c in ticks]
    events += [(c.cycle, 2, k) for k, c in enumerate(changes)]
    events.sort()
    before = -1
    for c, kind, b in events:
        ends = kind == 1 and (b == 0x0D or (b == 0x0A and before != 0x0D))
        before = b if kind == 1 else before
        if ends and any(abs(c - t) < margin for t in ticks):
            raise ProtocolError(f"a line ends at cycle {c}, within {margin} cycles of a tick: "
                                "which comes first is not the logic's (move the line)")
    pending = bytearray()
    for _, kind, b in events:
        if kind == 0:
            pending += core.tick()
        elif kind == 1:
            pending += core.feed(bytes([b]))
        else:
            sensors[changes[b].sensor].change(changes[b])
    run.replies = reply_lines(bytes(pending))
    return run


def compare(python: Run, sim: Run, name: str) -> list[str]:
    """Differences, one message per part; [] when the runs agree (``name``: the
    simulator's, for the messages)."""
    diffs = []
    parts = [("replies", python.replies, sim.replies), ("I2C writes", python.writes, sim.writes)]
    parts += [(f"flow sensor {i} reads", a, b)
              for i, (a, b) in enumerate(zip(python.flow, sim.flow, strict=True))]
    for what, a, b in parts:
        if a != b:
            first = next((i for i, (x, y) in enumerate(zip(a, b)) if x != y), min(len(a), len(b)))
            diffs.append(f"{what}: {len(a)} in Python, {len(b)} in {name}; first difference "
                         f"at {first}: {a[first] if first < len(a) else '-'} / "
                         f"{b[first] if first < len(b) else '-'}")
    return diffs
