"""The drive board's behaviour in Python: its register map, the ramp, the limits and
the PWM duty of each wheel (what the generated C will do, in the same integers).

Every control tick (:data:`CONTROL_TICK_MS`) each motor takes its wanted speed from the
register map (signed 16-bit mm/s, low byte first), clamps it to ``limit_mm_s``, moves
its speed toward it by at most ``ramp_mm_s2 * tick`` and sets the duty
``|speed| * 255 / full_speed`` (rounded down, through a precomputed 8.8 factor) and the
direction pin (high = forward, inverted by ``reverse``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

CONTROL_TICK_MS = 10
#: Software PWM: steps per period, and the timer interrupt's rate (the CCP units run at
#: the hardware PWM frequency of Timer2, whose postscaled interrupt this is; a whole
#: number of them make the control tick: codegen/drive.py).
SOFT_PWM_STEPS = 64
SOFT_PWM_ISR_HZ = 10000


def to_s16(low: int, high: int) -> int:
    v = low | (high << 8)
    return v - 0x10000 if v & 0x8000 else v


def from_s16(v: int) -> tuple[int, int]:
    v &= 0xFFFF
    return v & 0xFF, v >> 8


@dataclass
class MotorState:
    """One wheel: the constants of its table row and what it does now."""

    name: str
    limit: int          # mm/s
    step: int           # mm/s per control tick
    duty_q8: int        # duty = |speed| * duty_q8 >> 8, at most 255
    reverse: bool
    full_speed: float   # mm/s at full duty (the world's wheel)
    speed: int = 0      # mm/s, ramped
    duty: int = 0
    forward: bool = True

    @property
    def rim_speed(self) -> float:
        """The rim speed the wheel turns at (mm/s), from its duty and direction."""
        v = self.duty * self.full_speed / 255
        return v if self.forward != self.reverse else -v


def motor_state(m: Any) -> MotorState:
    full = m.full_speed_mm_s
    return MotorState(m.name, m.limit_mm_s, max(1, m.ramp_mm_s2 * CONTROL_TICK_MS // 1000),
                      round(255 * 256 / full), m.reverse, full)


class DriveCore:
    """The drive board: an I2C register map and the control tick.

    A tick after which every motor runs at the speed its register asks for, and no write
    came since that changed a register, changes nothing: the next such tick is skipped
    (``rims`` and the motors' state are those the skipped ticks would compute)."""

    def __init__(self, board: Any):
        self.motors = [motor_state(m) for m in sorted(board.motors, key=lambda m: m.index)]
        self.regs = bytearray(2 * len(self.motors))
        self.address = board.i2c.address
        self._settled = False         # every motor at its wanted speed, no write since
        #: Each wheel's rim speed (mm/s) as the last tick left it.
        self.rims: tuple[float, ...] = tuple(m.rim_speed for m in self.motors)

    def write(self, first: int, data: bytes) -> None:
        """A master's write: register pointer ``first``, then the bytes (auto-increment,
        wrapping at the map's end)."""
        regs = self.regs
        n = len(regs)
        if first + len(data) <= n:
            if regs[first:first + len(data)] == data:
                return                # the same speeds again: a settled board stays so
            regs[first:first + len(data)] = data
        else:
            for k, b in enumerate(data):
                regs[(first + k) % n] = b
        self._settled = False

    @property
    def settled(self) -> bool:
        """Every motor runs at the speed its register asks for and no write came since:
        a tick now changes nothing."""
        return self._settled

    def wanted(self, i: int) -> int:
        return to_s16(self.regs[2 * i], self.regs[2 * i + 1])

    def tick(self) -> None:
        if self._settled:
            return
        settled = True
        regs = self.regs
        for i, m in enumerate(self.motors):
            want = regs[2 * i] | (regs[2 * i + 1] << 8)
            if want & 0x8000:
                want -= 0x10000
            limit = m.limit
            if want > limit:
                want = limit
            elif want < -limit:
                want = -limit
            speed = m.speed
            speed = min(want, speed + m.step) if want > speed else max(want, speed - m.step)
            m.speed = speed
            m.duty = min(255, (abs(speed) * m.duty_q8) >> 8)
            m.forward = (speed >= 0) != m.reverse
            settled = settled and speed == want
        self._settled = settled
        self.rims = tuple(m.rim_speed for m in self.motors)

    def rim_speeds(self) -> list[float]:
        return list(self.rims)
