"""Servo pulses measured on the actuator board's pins in simavr, against what its
register writes and sync edges command (the actuator core's rules, in Python).

The actuator latches its register map at each falling edge of the sync line, steps
every position toward its target by its speed, and the new widths apply from the next
20 ms PWM frame; a pulse is checked against the positions of the latest latch at least
``SETTLE_US`` before it rose (pulses rising closer to a latch are left out: the frame
may have started before the ISR took the new schedule)."""

from __future__ import annotations

from dataclasses import dataclass

from esair_min.model.encoding import encode_pair
from esair_min.avr.simavr_harness import AvrRun, Pulse, pulses
from esair_min.model.robot import Robot
from esair_min.pic.gpsim_servo import expected_us

SETTLE_US = 1000


@dataclass(frozen=True)
class PulseCheck:
    pulse: Pulse
    angle: int
    expected_us: float

    @property
    def error(self) -> float:
        return (self.pulse.width_us - self.expected_us) / self.expected_us


def _apply(regs: list[int], data: bytes) -> None:
    p = data[0] % len(regs)
    for b in data[1:]:
        regs[p] = b
        p = (p + 1) % len(regs)


def checked_pulses(run: AvrRun, robot: Robot, clock_hz: int) -> tuple[list[PulseCheck], int]:
    """Each pulse with the angle commanded at its time; and how many were left out."""
    servos = sorted(robot.servos, key=lambda x: x.index)
    act = robot.peer("actuator")
    assert act is not None
    regs = [b for x in servos for b in encode_pair(x.stand_angle, x.default_speed)]
    position = [x.stand_angle for x in servos]
    target = list(position)
    speed = [x.default_speed for x in servos]
    writes = sorted((t.stop, t.segments[0].payload()) for t in run.transfers
                    if t.stop is not None and t.segments and t.segments[0].address == act.address
                    and not t.segments[0].reading and t.segments[0].addr_ack)
    falls = [c for c, v in run.sync_edges if v == 0 and c > 0]
    latches: list[tuple[int, list[int]]] = [(0, list(position))]
    w = 0
    for f in falls:
        while w < len(writes) and writes[w][0] < f:
            _apply(regs, writes[w][1])
            w += 1
        for i, x in enumerate(servos):
            low, high = regs[2 * i], regs[2 * i + 1]
            if low < 100:
                target[i] = min(max((high % 10) * 100 + low, x.min_angle), x.max_angle)
                speed[i] = high // 10
            s = speed[i]
            if s == 0 or abs(target[i] - position[i]) <= s:
                position[i] = target[i]
            else:
                position[i] += s if target[i] > position[i] else -s
        latches.append((f, list(position)))
    settle = SETTLE_US * clock_hz // 1_000_000
    out, skipped = [], 0
    for p in pulses(run, robot, clock_hz):
        before = [pos for c, pos in latches if c <= p.rise]
        last = max(c for c, _ in latches if c <= p.rise)
        if 0 < p.rise - last < settle:
            skipped += 1
            continue
        angle = before[-1][p.servo]
        out.append(PulseCheck(p, angle, expected_us(servos[p.servo], angle)))
    return out, skipped


#: The superloop functions that bound one servo update on the actuator board: from the
#: latch of the register map to the next pass's watchdog clear (step, 12 pulse widths,
#: the PWM schedule in between).
UPDATE_FROM, UPDATE_TO = "act_latch", "hal_watchdog_clear"


def update_spans(run: AvrRun, start: int, end: int) -> list[tuple[int, int]]:
    """(cycle, cycles) of each servo update in a run that watched the actuator at the
    byte addresses ``start`` (UPDATE_FROM) and ``end`` (UPDATE_TO): each ``start`` to
    the first ``end`` after it."""
    spans, began = [], None
    for cycle, at in run.hits:
        if at == start:
            began = cycle
        elif at == end and began is not None:
            spans.append((began, cycle - began))
            began = None
    return spans
