"""An ADNS-2610-class optical mouse sensor in Python: its registers, its serial-port
timing, and the floor motion it sees.

Registers (ADNS-2610 datasheet): 0x00 Configuration, 0x01 Status (product ID in bits
7..5 = 000, bit 0 awake), 0x02 Delta_Y, 0x03 Delta_X (signed counts since the last read
of that register, saturating at -128..127; reading one clears it), 0x04 SQUAL (surface
quality: about half the number of features seen, 0 when lifted). The 2610 has no
separate motion register: motion is a non-zero delta. The "motion" bit the odometry
reply gives is that.

Serial timing (two-wire, SCLK and bidirectional SDIO): a register's data may be clocked
out no sooner than tSRAD = 100 us after its address byte; the next address may follow a
read after tSRR = 0.25 us; after a write, tSWW/tSWR = 100 us. A reader breaking one of
these gets :class:`FlowTimingError` (in the firmware it would read garbage).

The sensor tracks up to :data:`MAX_SPEED_IPS` inches per second; faster, or lifted, the
motion of that interval is lost (counted in ``lost``). Counts carry Gaussian noise
(``noise``: a fraction of the motion), seeded.
"""

from __future__ import annotations

import math
import random
from dataclasses import dataclass, field

from esair_min.core.odometry import MM_PER_INCH

REG_CONFIG = 0x00
REG_STATUS = 0x01
REG_DELTA_Y = 0x02
REG_DELTA_X = 0x03
REG_SQUAL = 0x04
T_SRAD_NS = 100_000
T_SRR_NS = 250
T_SWW_NS = 100_000
MAX_SPEED_IPS = 12.0
#: One register read by the central board: address, tSRAD, 8 bits, tSRR, 8 bits.
_READ_NS = T_SRAD_NS + 8_000 + T_SRR_NS + 8_000
#: A burst of the three reads (:meth:`Adns2610.deltas`): the sensor is free again, and
#: the reader done, this long after the first address (the SQUAL's data byte, then tSRR,
#: then 8 bits).
BURST_FREE_NS = 2 * _READ_NS + T_SRAD_NS + 8_000 + T_SRR_NS
BURST_END_NS = BURST_FREE_NS + 8_000
TWOPI = 2.0 * math.pi                   # random.TWOPI
_sqrt, _log, _cos, _sin, _hypot = math.sqrt, math.log, math.cos, math.sin, math.hypot


class FlowTimingError(Exception):
    """A register access broke the sensor's serial timing."""


@dataclass
class Adns2610:
    """One sensor: feed it floor motion (:meth:`move`), read it like the firmware does."""

    cpi: int = 400
    surface: int = 90          # SQUAL on this floor
    noise: float = 0.0         # standard deviation of the counts, as a fraction of the motion
    seed: int = 0
    lifted: bool = False
    lost: int = 0              # motion intervals lost (lifted or too fast)
    config: int = 0x01         # force awake
    _acc: list[float] = field(default_factory=lambda: [0.0, 0.0])   # x, y counts not yet read
    _addr_at: int | None = None
    _free_at: int = 0

    def __post_init__(self) -> None:
        self._rng = random.Random(self.seed)

    # -- the world's side ------------------------------------------------------------
    def move(self, dx_mm: float, dy_mm: float, dt_s: float) -> None:
        """The sensor moved (dx, dy) mm in its own frame over ``dt_s`` seconds."""
        dist = _hypot(dx_mm, dy_mm)
        if self.lifted or (dt_s > 0 and dist / MM_PER_INCH / dt_s > MAX_SPEED_IPS):
            if dist:
                self.lost += 1
            return
        k = self.cpi / MM_PER_INCH
        acc = self._acc
        noise = self.noise
        if noise:                          # x first, then y: the seeded sequence
            rng = self._rng
            if rng.gauss_next is None:            # type: ignore[attr-defined]
                # random.Random.gauss inlined: one call draws a pair and keeps the
                # second for the next call, so x takes the pair's first and y its
                # second (the same floats, and the generator left as two calls leave it)
                random = rng.random
                x2pi = random() * TWOPI
                g2rad = _sqrt(-2.0 * _log(1.0 - random()))
                acc[0] += (dx_mm + (0.0 + _cos(x2pi) * g2rad * (noise * abs(dx_mm)))) * k
                acc[1] += (dy_mm + (0.0 + _sin(x2pi) * g2rad * (noise * abs(dy_mm)))) * k
            else:
                gauss = rng.gauss
                acc[0] += (dx_mm + gauss(0.0, noise * abs(dx_mm))) * k
                acc[1] += (dy_mm + gauss(0.0, noise * abs(dy_mm))) * k
        else:
            acc[0] += (dx_mm + 0.0) * k
            acc[1] += (dy_mm + 0.0) * k

    # -- the serial port ---------------------------------------------------------------
    def address(self, reg: int, t_ns: int) -> None:
        """The reader clocked a read address (bit 7 clear) out at ``t_ns``."""
        if t_ns < self._free_at:
            raise FlowTimingError(f"address 0x{reg:02X} at {t_ns} ns, before the sensor is "
                                  f"ready at {self._free_at} ns")
        self._addr_at = t_ns
        self._reg = reg

    def data(self, t_ns: int) -> int:
        """The reader clocks the data byte in, starting at ``t_ns``."""
        if self._addr_at is None:
            raise FlowTimingError("a data read without an address")
        if t_ns - self._addr_at < T_SRAD_NS:
            raise FlowTimingError(f"data read {t_ns - self._addr_at} ns after the address; "
                                  f"the sensor needs tSRAD = {T_SRAD_NS} ns")
        self._addr_at = None
        self._free_at = t_ns + T_SRR_NS
        return self.register(self._reg)

    def write(self, reg: int, value: int, t_ns: int) -> None:
        if t_ns < self._free_at:
            raise FlowTimingError(f"write to 0x{reg:02X} at {t_ns} ns, before the sensor is "
                                  f"ready at {self._free_at} ns")
        if reg == REG_CONFIG:
            self.config = value & 0xFF
        self._free_at = t_ns + T_SWW_NS

    def deltas(self, t_ns: int) -> tuple[int, int, int, int]:
        """:func:`read_deltas` on this sensor (the same reads, checks and state after),
        without a call per register: the central board's tick calls it."""
        if t_ns < self._free_at:
            raise FlowTimingError(f"address 0x{REG_DELTA_Y:02X} at {t_ns} ns, before the "
                                  f"sensor is ready at {self._free_at} ns")
        acc = self._acc
        dy = int(acc[1])                   # Delta_Y first, as the firmware reads
        if dy:                             # (x - 0 is x: nothing to take when 0)
            dy = -128 if dy < -128 else 127 if dy > 127 else dy
            acc[1] -= dy
        dx = int(acc[0])
        if dx:
            dx = -128 if dx < -128 else 127 if dx > 127 else dx
            acc[0] -= dx
        self._reg = REG_SQUAL
        self._addr_at = None
        self._free_at = t_ns + BURST_FREE_NS
        return dx, dy, 0 if self.lifted else self.surface, t_ns + BURST_END_NS

    def register(self, reg: int) -> int:
        """A register's value as read (reading a delta clears it)."""
        if reg == REG_CONFIG:
            return self.config
        if reg == REG_STATUS:
            return 0x01
        if reg in (REG_DELTA_X, REG_DELTA_Y):
            axis = 0 if reg == REG_DELTA_X else 1
            whole = int(self._acc[axis])          # toward zero; the rest stays
            out = max(-128, min(127, whole))
            self._acc[axis] -= out
            return out & 0xFF
        if reg == REG_SQUAL:
            return 0 if self.lifted else self.surface
        raise FlowTimingError(f"register 0x{reg:02X} is not modelled")


def s8(b: int) -> int:
    return b - 0x100 if b & 0x80 else b


def read_deltas(sensor: Adns2610, t_ns: int) -> tuple[int, int, int, int]:
    """What the central board's reader does each tick: Delta_Y, Delta_X, SQUAL, each
    address then data after tSRAD (plus a bit time). Returns (dx, dy, squal, t_end)."""
    t = t_ns
    out = {}
    for reg in (REG_DELTA_Y, REG_DELTA_X, REG_SQUAL):
        sensor.address(reg, t)
        t += T_SRAD_NS + 8_000          # tSRAD, then 8 bits at 1 us a bit
        out[reg] = sensor.data(t)
        t += T_SRR_NS + 8_000
    return s8(out[REG_DELTA_X]), s8(out[REG_DELTA_Y]), out[REG_SQUAL], t
