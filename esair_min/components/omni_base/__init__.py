"""Kind ``omni_base`` (section ``base``, one per central board): the central board of an
omni-wheel robot (STARFISH). It turns the PC's body velocity (vx, vy in mm/s, omega in
mrad/s) into the wheel speeds of the drive board by the omni-wheel kinematics
(:mod:`.kinematics`, in integers as the MCU computes it, geometry from the drive board's
``motors``), enforces the body and wheel limits, and stops every wheel when no valid
command came for ``watchdog_ms`` (a notice says so). Its command set is fixed
(docs/protocol.md, STARFISH); its Python core is :mod:`.core`.
"""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import Field, StrictInt

from esair_min.components.base import Checker, Component
from esair_min.components.omni_base.kinematics import Wheel, determinant, wheel_table
from esair_min.model.types import Section

WHEELS = 3


class OmniBase(Section):
    """The omni-wheel base driven through the central board."""

    watchdog_ms: Annotated[StrictInt, Field(ge=20, le=10000)] = Field(
        500, description="stop every wheel when no valid command came for this long")
    max_speed_mm_s: Annotated[StrictInt, Field(ge=1, le=9999)] = Field(
        500, description="the largest |vx| and |vy| a command may ask")
    max_omega_mrad_s: Annotated[StrictInt, Field(ge=1, le=9999)] = Field(
        3000, description="the largest |omega| a command may ask")


def wheels_of(drive: Any) -> list[Wheel]:
    return wheel_table(sorted(drive.motors, key=lambda m: m.index))


def pairing_rules(checker: Checker, central: Any, by_role: dict[str, Any]) -> None:
    """A drive board and a base come together (checked before the command table)."""
    drive = by_role.get("drive")
    if central.base is None and drive is not None:
        checker.fail(drive, ("role",), "a drive board needs 'base:' on the central board "
                     "(the omni-wheel kinematics that drive it)")


def robot_rules(checker: Checker, central: Any, by_role: dict[str, Any]) -> None:
    drive = by_role.get("drive")
    if central.base is None:
        return
    if drive is None:
        checker.fail(central, ("base",), "'base' needs a drive board (role: drive) with "
                     f"{WHEELS} motors in this robot", key=True)
    if len(drive.motors) != WHEELS:
        checker.fail(drive, ("motors",), f"an omni base has {WHEELS} wheels, but this drive "
                     f"board has {len(drive.motors)} motors", key=True)
    if abs(determinant(wheels_of(drive))) < 1e-3:
        checker.fail(drive, ("motors",), "the wheels' mount angles do not let the base move "
                     "in every direction (the kinematics cannot be inverted); place the "
                     "wheels at different angles, e.g. 90, 210, 330", key=True)
    for name in ("servos", "sensors", "motions", "reactions"):
        if getattr(central, name) or (name in ("servos", "sensors") and any(
                getattr(b, name) for b in by_role.values())):
            where = central if getattr(central, name) else next(
                b for b in by_role.values() if getattr(b, name))
            checker.fail(where, (name,), f"an omni-base robot has no '{name}'", key=True)
    if central.commands:
        checker.fail(central, ("commands",), "an omni base's commands are fixed "
                     "(docs/protocol.md, STARFISH); remove 'commands'", key=True)


def summary(central: Any) -> list[str]:
    b = central.base
    if b is None:
        return []
    return [f"  base: omni, watchdog {b.watchdog_ms} ms, |v| <= {b.max_speed_mm_s} mm/s, "
            f"|omega| <= {b.max_omega_mrad_s} mrad/s"]


COMPONENT = Component(
    kind="omni_base", section="base", schema=OmniBase, roles=("central",), many=False,
    description="an omni-wheel base driven through a drive board (central only)",
    robot_rules=robot_rules, summary=summary)
