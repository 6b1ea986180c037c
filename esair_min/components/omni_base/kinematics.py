"""Omni-wheel kinematics, in the integers the MCU computes with.

Wheel *i* sits at angle a_i around the centre, r_i mm from it, and drives tangentially
(counter-clockwise positive). For a body velocity (vx, vy in mm/s, omega in rad/s) in
the robot's frame its rim speed is ``-sin(a_i) vx + cos(a_i) vy + r_i omega``.

On the MCU (and here, bit for bit): ``S_i = round(-sin a_i * 2^14)``,
``C_i = round(cos a_i * 2^14)``, ``R_i = round(r_i * 2^14 / 1000)`` (omega comes in
mrad/s), and ``v_i = (S_i vx + C_i vy + R_i omega + 2^13) >> 14`` in 32 bits (an
arithmetic shift: rounds half up). With |vx|, |vy|, |omega| <= 9999 and r_i <= 2000 mm
the sum stays within 2^31.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

Q = 14
HALF = 1 << (Q - 1)


@dataclass(frozen=True)
class Wheel:
    """One wheel's constants (the MCU's table row) and its geometry."""

    s: int          # -sin(a) * 2^14
    c: int          # cos(a) * 2^14
    r: int          # r_mm * 2^14 / 1000
    angle_rad: float
    radius_mm: float
    limit_mm_s: int


def wheel_table(motors: list[Any]) -> list[Wheel]:
    """The wheels of ``motors`` (dc_motor items, in index order)."""
    out = []
    for m in motors:
        a = math.radians(m.mount_angle_deg)
        out.append(Wheel(round(-math.sin(a) * (1 << Q)), round(math.cos(a) * (1 << Q)),
                         round(m.mount_radius_mm * (1 << Q) / 1000), a,
                         float(m.mount_radius_mm), m.limit_mm_s))
    return out


def wheel_speeds(wheels: list[Wheel], vx: int, vy: int, omega_mrad: int) -> list[int]:
    """Rim speeds (mm/s) for a body velocity, as the MCU computes them."""
    return [(w.s * vx + w.c * vy + w.r * omega_mrad + HALF) >> Q for w in wheels]


def matrix(wheels: list[Wheel]) -> list[list[float]]:
    """The exact (float) map from (vx, vy, omega rad/s) to rim speeds."""
    return [[-math.sin(w.angle_rad), math.cos(w.angle_rad), w.radius_mm] for w in wheels]


def determinant(wheels: list[Wheel]) -> float:
    if len(wheels) != 3:
        return 0.0
    (a, b, c), (d, e, f), (g, h, i) = matrix(wheels)
    return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)


def inverse(wheels: list[Wheel]) -> list[list[float]]:
    """The map from three rim speeds to (vx, vy mm/s, omega rad/s): the matrix's inverse."""
    (a, b, c), (d, e, f), (g, h, i) = matrix(wheels)
    det = determinant(wheels)
    return [[(e * i - f * h) / det, (c * h - b * i) / det, (b * f - c * e) / det],
            [(f * g - d * i) / det, (a * i - c * g) / det, (c * d - a * f) / det],
            [(d * h - e * g) / det, (b * g - a * h) / det, (a * e - b * d) / det]]


def body_velocity(wheels: list[Wheel], speeds: list[float],
                  inv: list[list[float]] | None = None) -> tuple[float, float, float]:
    """(vx, vy mm/s, omega rad/s) that the three rim speeds give (``inv``: the
    precomputed :func:`inverse`)."""
    m = inv if inv is not None else inverse(wheels)
    s0, s1, s2 = speeds
    return (m[0][0] * s0 + m[0][1] * s1 + m[0][2] * s2,
            m[1][0] * s0 + m[1][1] * s1 + m[1][2] * s2,
            m[2][0] * s0 + m[2][1] * s1 + m[2][2] * s2)
