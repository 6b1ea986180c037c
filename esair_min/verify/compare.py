"""Each target's trace against the Python core's: equal, or the first differing events
side by side with the script line (the command) that led to them.

- host: the whole trace, line for line (ticks, replies, every I2C transfer);
- pic, avr: what a chip must reproduce however its bytes and ticks interleave (the
  gpsim harness's ``compare``): the reply lines, the actuator writes and the EEPROM
  reads in order, the sensor reads as a set (a chip's timer runs from reset, so it
  polls a few more times); and the timing: each actuator write on the Python core's
  tick, within the tolerance :func:`tick_tolerance` states.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from esair_min.model.robot import Robot
from esair_min.verify.targets import TargetRun


@dataclass
class Difference:
    """The first events that differ: what the Python core did, what the target did,
    and the script line that led to the Python core's event."""

    part: str                    # "trace", "uart", "actuator", "eeprom", "sensor", "timing"
    index: int                   # position in that part
    python: str
    target: str
    line: int = 0                # script line number (0: unknown)
    command: str = ""            # that script line's text
    note: str = ""


@dataclass
class Comparison:
    target: str
    events: int                                    # events compared
    differences: list[Difference] = field(default_factory=list)

    @property
    def equal(self) -> bool:
        return not self.differences


def _command(script: str, line: int) -> str:
    """Script line ``line``; when it is not an ``rx`` line, the last ``rx`` line before it
    (the command whose reply or writes came in the ticks that followed) too."""
    lines = script.splitlines()
    if not 0 < line <= len(lines):
        return ""
    text = lines[line - 1].strip()
    if text.startswith("rx"):
        return text
    sent = next((k for k in range(line - 1, 0, -1) if lines[k - 1].lstrip().startswith("rx")), 0)
    return f"{lines[sent - 1].strip()} (line {sent}), then {text}" if sent else text


def compare_host(py: TargetRun, host: TargetRun, script: str) -> Comparison:
    """Line for line."""
    out = Comparison("host", len(py.trace))
    a, b = py.trace, host.trace
    if a == b:
        return out
    i = next((k for k, (x, y) in enumerate(zip(a, b)) if x != y), min(len(a), len(b)))
    line = py.causes[i] if i < len(py.causes) else (py.causes[-1] if py.causes else 0)
    out.differences.append(Difference("trace", i + 1, a[i] if i < len(a) else "(end)",
                                      b[i] if i < len(b) else "(end)", line,
                                      _command(script, line)))
    return out


def _parts(lines: list[str], robot: Robot) -> dict[str, list[tuple[int, str]]]:
    """(trace index, normalised line) of the UART lines and of each device's transfers.

    A refused transfer is its address alone (``NACK aa``): on the wire the master stops
    at the refused address byte, where the Python core lists what it wanted to send (a
    read refused at its register-pointer write shows as a write). A probe, an address
    with no data (an I2C scan, ACK polling), acknowledged, is ``P aa ACK``."""
    eep, act, sen = robot.eeprom, robot.peer("actuator"), robot.peer("sensor")
    by_addr = {d.address: name for name, d in (("eeprom", eep), ("actuator", act),
                                               ("sensor", sen)) if d is not None}
    out: dict[str, list[tuple[int, str]]] = {"uart": [], "actuator": [], "eeprom": [],
                                             "sensor": []}
    for i, line in enumerate(lines):
        words = line.split()
        if line.startswith("TX "):
            out["uart"].append((i, line))
        elif words[0] in ("P", "W", "R") and len(words) >= 3:
            key = by_addr.get(int(words[1], 16), "unknown")
            if words[-1] == "NACK":
                out.setdefault(key, []).append((i, f"NACK {words[1]}"))
            elif words[0] == "P" or (words[0] == "W" and len(words) == 3):
                out.setdefault("probe", []).append((i, f"P {words[1]} ACK"))
            else:
                out.setdefault(key, []).append((i, line))
    return out


def _ticks(lines: list[str]) -> list[int]:
    """The tick number each trace line falls in (the last ``T n`` before it)."""
    out, tick = [], 0
    for line in lines:
        if line.startswith("T "):
            tick = int(line.split()[1])
        out.append(tick)
    return out


def tick_tolerance(robot: Robot, command_bytes: int) -> int:
    """Ticks an actuator write may land later in a chip than in the Python core: the
    ticks its command line takes to arrive at the board's baud (the Python core gets a
    line at once), plus one."""
    uart, t = robot.central.uart, robot.central.timer2
    assert uart is not None and t is not None
    return int(command_bytes * 10 / uart.baud / t.period_s) + 1


def compare_chip(py: TargetRun, chip: TargetRun, script: str, robot: Robot) -> Comparison:
    a = _parts(py.trace, robot)
    b = _parts(chip.trace, robot)
    out = Comparison(chip.target, sum(len(v) for v in a.values()))

    def diff(part: str, k: int, note: str = "") -> Difference:
        pa, pb = a.get(part, []), b.get(part, [])
        i = pa[k][0] if k < len(pa) else (pa[-1][0] if pa else 0)
        line = py.causes[i] if i < len(py.causes) else 0
        return Difference(part, k + 1, pa[k][1] if k < len(pa) else "(none)",
                          pb[k][1] if k < len(pb) else "(none)", line,
                          _command(script, line), note)

    for part in ("uart", "actuator", "eeprom", "probe", "unknown"):
        x, y = [s for _, s in a.get(part, [])], [s for _, s in b.get(part, [])]
        if x != y:
            k = next((j for j, (p, q) in enumerate(zip(x, y)) if p != q), min(len(x), len(y)))
            out.differences.append(diff(part, k))
    xs, ys = {s for _, s in a["sensor"]}, {s for _, s in b["sensor"]}
    if xs != ys:
        missing = sorted(xs - ys) + sorted(ys - xs)
        k = next((j for j, (_, s) in enumerate(a["sensor"]) if s in missing), 0)
        out.differences.append(diff("sensor", k, "sensor reads differ in content"))
    if not out.differences:
        late = _timing(py, chip, a["actuator"], b["actuator"], robot, script)
        if late is not None:
            out.differences.append(late)
    return out


def _chip_ticks(chip: TargetRun, robot: Robot, n: int) -> list[int] | None:
    """The Timer period of each of the chip's first ``n`` actuator writes, counted from
    its first sync rising edge: a period whose work overran has no rising edge of its own
    (the pin stays high), so the trace's ``T`` lines would undercount them."""
    sim, act = chip.sim, robot.peer("actuator")
    if sim is None or act is None:
        return None
    if chip.target == "pic":
        from esair_min.pic.gpsim_harness import GpsimSetup

        tick = GpsimSetup.from_robot(robot).tick_cycles
    else:
        from esair_min.avr.simavr_harness import AvrSetup

        tick = AvrSetup.from_robot(robot).tick_cycles
    ups = [c for c, v in sim.sync_edges if v == 1 and c > 0]
    starts = [t.start for t in sim.transfers if t.segments and t.segments[0].address
              == act.address and not t.segments[0].reading
              and (t.segments[0].data or not t.segments[0].addr_ack)]     # no probes
    if not ups or len(starts) < n:
        return None
    return [(c - ups[0]) // tick for c in starts[:n]]


def _timing(py: TargetRun, chip: TargetRun, pa: list[tuple[int, str]],
            pb: list[tuple[int, str]], robot: Robot, script: str) -> Difference | None:
    """The first actuator write whose tick, counted from the first write, differs from
    the Python core's by more than :func:`tick_tolerance` of its command line (later), or
    by more than that of the first write's line (earlier: the first one came late)."""
    if not pa:
        return None
    ta = _ticks(py.trace)
    tb = _chip_ticks(chip, robot, len(pb))
    if tb is None:
        t_lines = _ticks(chip.trace)
        tb = [t_lines[j] for j, _ in pb]
    a0, b0 = ta[pa[0][0]], tb[0]

    def sent_before(i: int) -> tuple[int, int]:
        line = py.causes[i] if i < len(py.causes) else 0
        command = _command(script, line)
        return (len(command[3:].split(" (line")[0]) if command.startswith("rx ") else 0), line

    early = tick_tolerance(robot, sent_before(pa[0][0])[0])   # the first write's own lateness
    for k, ((i, text), chip_tick) in enumerate(zip(pa, tb)):
        sent, line = sent_before(i)
        command = _command(script, line)
        drift = (chip_tick - b0) - (ta[i] - a0)
        if drift < -early or drift > tick_tolerance(robot, sent):
            return Difference("timing", k + 1, f"{text} at tick {ta[i] - a0} after the first write",
                              f"at tick {chip_tick - b0}", line, command,
                              f"tolerance {tick_tolerance(robot, sent)} tick(s)")
    return None
