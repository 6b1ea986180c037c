"""``esair plot``: servo angles over time from an event trace (docs/trace-format.md).

The trace's ``W`` lines to the actuator board's address are decoded into register
writes. The plot shows **simulated servo positions**: the register map is replayed
through the emulator's servo model tick by tick (latched at the sync edge that follows
the tick's writes, then moved by *speed* degrees per tick toward the target, 0 = at
once), exactly
as the emulated actuator board moves. With ``targets=True`` the decoded targets are
drawn too, as dashed steps. ``!R`` notices (reactions firing) are marked.

Layout: one small panel per joint (left leg and right leg side by side), so curves
that coincide never hide each other; below them, on the same time axis, the foot
sensors as the central board read them (the ``R`` lines from the sensor board: each
group's sum) and the difference a balance reaction compares with its threshold; the
legend stands above the panels, outside the data. A trace without actuator writes is
drawn too: flat at the stand pose, with a note saying so.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from esair_min.emulator.papaman.actuator import ServoBank, stand_registers
from esair_min.errors import EsairError
from esair_min.model.robot import Robot

TAIL_TICKS = 100   # ticks plotted after the last event at most, while servos still move


@dataclass
class TraceEvents:
    last_tick: int = 0
    writes: dict[int, list[bytes]] = field(default_factory=dict)   # tick -> W payloads
    reactions: list[tuple[int, str]] = field(default_factory=list)  # (tick, name)
    readings: list[tuple[int, tuple[int, ...]]] = field(default_factory=list)  # sensor reads


def read_trace(path: Path | str, actuator: int, sensor: int | None = None) -> TraceEvents:
    """The events of a trace file: actuator writes and (given the sensor board's
    address) sensor readings by tick, and the reactions that fired."""
    try:
        text = Path(path).read_text(encoding="ascii", errors="replace")
    except OSError as exc:
        raise EsairError(f"cannot read the trace {path}: {exc.strerror}") from None
    lines = text.splitlines()
    if not lines or lines[0].strip() != "# esair-trace 1":
        raise EsairError(f"{path}: not an event trace (its first line must be "
                         "'# esair-trace 1')")
    ev = TraceEvents()
    tick = 0
    for no, line in enumerate(lines[1:], start=2):
        parts = line.split()
        if not parts:
            continue
        try:
            if parts[0] == "T":
                tick = int(parts[1])
                ev.last_tick = max(ev.last_tick, tick)
            elif parts[0] == "W" and int(parts[1], 16) == actuator and parts[-1] == "ACK":
                ev.writes.setdefault(tick, []).append(bytes.fromhex(parts[2]))
            elif (parts[0] == "R" and sensor is not None and int(parts[1], 16) == sensor
                  and parts[4] != "NACK"):
                data = bytes.fromhex(parts[4])
                ev.readings.append((tick, tuple(int.from_bytes(data[i:i + 2], "little")
                                                for i in range(0, len(data) - 1, 2))))
            elif parts[0] == "TX":
                msg = bytes.fromhex(parts[1]).decode("latin-1").strip()
                if msg.startswith("!R "):
                    ev.reactions.append((tick, msg[3:]))
        except (IndexError, ValueError):
            raise EsairError(f"{path}:{no}: malformed trace line: {line!r}") from None
    return ev


def replay(robot: Robot, ev: TraceEvents) -> tuple[list[int], list[list[int]], list[list[int]]]:
    """(ticks, positions per tick, targets per tick) replayed through the servo model."""
    servos = robot.servos
    regs = bytearray(stand_registers(servos))
    bank = ServoBank(servos)
    ticks, pos, tgt = [0], [list(bank.angles)], [list(bank.targets)]
    for payload in ev.writes.get(0, []):
        _apply(regs, payload)
    k = 0
    while True:
        k += 1
        moving = bank.angles != bank.targets
        if k > ev.last_tick and (not moving or k > ev.last_tick + TAIL_TICKS):
            break
        for payload in ev.writes.get(k, []):
            _apply(regs, payload)
        bank.latch(regs)          # sync pin: latch what this tick wrote
        bank.step()
        ticks.append(k)
        pos.append(list(bank.angles))
        tgt.append(list(bank.targets))
    return ticks, pos, tgt


def _apply(regs: bytearray, payload: bytes) -> None:
    if not payload:
        return
    p = payload[0] % len(regs)
    for b in payload[1:]:
        regs[p] = b
        p = (p + 1) % len(regs)


def plot_trace(robot: Robot, trace: Path | str, out: Path | str, targets: bool = False) -> int:
    """Draw the servo angles of ``trace`` into the PNG ``out``; returns the ticks drawn."""
    act = robot.peer("actuator")
    if act is None or not robot.servos:
        raise EsairError(f"robot {robot.name} has no actuator board to plot")
    sen = robot.peer("sensor")
    ev = read_trace(trace, act.address, sen.address if sen else None)
    ticks, pos, tgt = replay(robot, ev)
    period = robot.central.timer2.period_s if robot.central.timer2 else 0.0

    import matplotlib

    matplotlib.use("Agg")
    from esair_min.cli.plotdraw import draw

    fig = draw(robot, ev, ticks, pos, tgt, period, targets, Path(trace).name)
    try:
        fig.savefig(out, dpi=100)
    except OSError as exc:
        raise EsairError(f"cannot write {out}: {exc.strerror}") from None
    finally:
        import matplotlib.pyplot as plt

        plt.close(fig)
    return len(ticks)
