"""Dead reckoning from the flow sensors' summed counts (what a host does with the
odometry reply): each poll's count differences give, per sensor, the displacement of
its mount point in its own frame; the body's displacement (dx, dy, dtheta) in the
robot's frame is their least-squares solution, integrated into a pose. A leaf of the
core (nothing of the board model): the robot side's odometry imports it alone.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from operator import mul
from typing import Any

#: Millimetres in an inch (a flow sensor counts per inch).
MM_PER_INCH = 25.4


def _det(a: float, b: float, c: float, d: float, e: float, f: float, g: float, h: float,
         i: float) -> float:
    """The determinant of the rows (a b c), (d e f), (g h i)."""
    return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)


def _solve3(a: list[list[float]], b: list[float]) -> list[float]:
    """Solve the 3x3 system a x = b (Cramer's rule)."""
    (a0, a1, a2), (a3, a4, a5), (a6, a7, a8) = a
    b0, b1, b2 = b
    d = _det(a0, a1, a2, a3, a4, a5, a6, a7, a8)
    return [_det(b0, a1, a2, b1, a4, a5, b2, a7, a8) / d,
            _det(a0, b0, a2, a3, b1, a5, a6, b2, a8) / d,
            _det(a0, a1, b0, a3, a4, b1, a6, a7, b2) / d]


class FlowOdometry:
    """Pose from the summed counts of two or more flow sensors (``sensors``: the
    central board's ``flow_sensors``). Feed :meth:`update` the sums of each poll."""

    def __init__(self, sensors: Sequence[Any], x: float = 0.0, y: float = 0.0,
                 theta: float = 0.0):
        if len(sensors) < 2:
            raise ValueError("dead reckoning with rotation needs two flow sensors")
        self.mm = [MM_PER_INCH / s.cpi for s in sensors]
        self.mounts = [(float(s.mount_x_mm), float(s.mount_y_mm),
                        math.radians(s.mount_angle_deg)) for s in sensors]
        # Rows of the linear map (dx, dy, dtheta) -> measured sensor displacements.
        rows = []
        for px, py, phi in self.mounts:
            c, s = math.cos(phi), math.sin(phi)
            rows.append((c, s, -c * py + s * px))      # the sensor's x
            rows.append((-s, c, s * py + c * px))      # the sensor's y
        self.rows = rows
        self.ata = [[sum(r[i] * r[j] for r in rows) for j in range(3)] for i in range(3)]
        # update's constants: the columns of the rows, and _solve3's determinant of ata
        # (the same matrix every poll: the same float)
        self._cols = [[r[i] for r in rows] for i in range(3)]
        self._a9 = tuple(v for row in self.ata for v in row)
        self._d = _det(*self._a9)
        self.x, self.y, self.theta = x, y, theta
        self.last: list[tuple[int, int]] | None = None

    def update(self, sums: Sequence[tuple[int, int]]) -> tuple[float, float, float]:
        """The summed (dx, dy) counts of every sensor at one poll: the new pose."""
        if len(sums) != len(self.mm):
            raise ValueError(f"sums of {len(sums)} flow sensors, not {len(self.mm)}")
        if self.last is None:
            self.last = [tuple(s) for s in sums]       # type: ignore[misc]
            return self.x, self.y, self.theta
        meas = []
        for k, ((sx, sy), (lx, ly)) in enumerate(zip(sums, self.last, strict=True)):
            meas += [(sx - lx) * self.mm[k], (sy - ly) * self.mm[k]]
        self.last = [tuple(s) for s in sums]           # type: ignore[misc]
        dx, dy, dth = self._solve([sum(map(mul, col, meas)) for col in self._cols])
        mid = self.theta + dth / 2
        self.x += math.cos(mid) * dx - math.sin(mid) * dy
        self.y += math.sin(mid) * dx + math.cos(mid) * dy
        self.theta += dth
        return self.x, self.y, self.theta

    def _solve(self, b: list[float]) -> tuple[float, float, float]:
        """:func:`_solve3` of ata with its determinant computed once (the same floats)."""
        a0, a1, a2, a3, a4, a5, a6, a7, a8 = self._a9
        b0, b1, b2 = b
        d = self._d
        return (_det(b0, a1, a2, b1, a4, a5, b2, a7, a8) / d,
                _det(a0, b0, a2, a3, b1, a5, a6, b2, a8) / d,
                _det(a0, a1, b0, a3, a4, b1, a6, a7, b2) / d)


def parse_odometry(reply: str) -> tuple[int, list[tuple[int, int, int]]]:
    """``OK n=12 a=1,2,90 b=3,4,88`` -> (12, [(1, 2, 90), (3, 4, 88)])."""
    parts = reply.split()
    if not parts or parts[0] != "OK" or not parts[1].startswith("n="):
        raise ValueError(f"not an odometry reply: {reply!r}")
    seq = int(parts[1][2:])
    sensors = []
    for p in parts[2:]:
        _, _, v = p.partition("=")
        dx, dy, q = map(int, v.split(","))
        sensors.append((dx, dy, q))
    return seq, sensors
