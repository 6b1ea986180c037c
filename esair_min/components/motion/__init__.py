"""Kind ``motion``: a stored motion on the central board, frames written to the actuator
one after the other from the EEPROM image (docs/eeprom-format.md). Its image is built
by :mod:`esair_min.core.image` over :mod:`.layout`, its player is
``firmware_templates/central`` and :mod:`esair_min.core.player`.
"""

from __future__ import annotations

from typing import Any

from esair_min.components.base import Checker, Component
from esair_min.components.motion.layout import image_layout
from esair_min.components.motion.schema import MAX_FRAMES, MAX_MOTIONS, Frame, Motion
from esair_min.components.servo import overflow
from esair_min.model.encoding import pair_fits


def storage_rules(checker: Checker, central: Any, by_role: dict[str, Any]) -> None:
    """Motions need an EEPROM, and their image must fit it and its 16-bit offsets."""
    eeprom = central.device("eeprom")
    if central.motions and eeprom is None:
        checker.fail(central, ("motions",), "motions need an EEPROM: add one to the I2C "
                     "devices (kind: eeprom)", key=True)
    if eeprom is None:
        return
    servos = len(by_role["actuator"].servos) if "actuator" in by_role else 0
    need = image_layout(central.motions, servos).total_bytes
    index = central.i2c.devices.index(eeprom)
    if need > 0xFFFF:
        checker.fail(central, ("motions",), f"the motion image needs {need} bytes, "
                     f"more than the 65535 its 16-bit offsets reach; use fewer or "
                     f"shorter motions", key=True)
    if need > eeprom.size_bytes:
        checker.fail(central, ("i2c", "devices", index, "size_bytes"),
                     f"the motion image needs {need} bytes but EEPROM '{eeprom.name}' "
                     f"has {eeprom.size_bytes} ({need - eeprom.size_bytes} bytes over); "
                     f"use a larger EEPROM or fewer frames")
    if eeprom.address_bytes == 1 and need > 256:
        checker.fail(central, ("i2c", "devices", index, "address_bytes"),
                     f"a 1-byte memory address reaches 256 bytes, but the motion image "
                     f"needs {need}; use address_bytes: 2")


def robot_rules(checker: Checker, central: Any, by_role: dict[str, Any]) -> None:
    """Every frame has one angle (and speed) per servo, each within its limits."""
    actuator = by_role.get("actuator")
    servos = sorted(actuator.servos, key=lambda s: s.index) if actuator else []
    if central.motions and not servos:
        checker.fail(central, ("motions", 0), "motions need an actuator board with servos")
    for i, m in enumerate(central.motions):
        for f, frame in enumerate(m.frames):       # each frame's first error
            checker.rule(_frame_rules, checker, central, ("motions", i, "frames", f), m, f,
                         frame, servos)


def _frame_rules(checker: Checker, central: Any, loc: tuple[Any, ...], m: Motion, f: int,
                 frame: Frame, servos: list[Any]) -> None:
    n = len(servos)
    if len(frame.angles) != n:
        checker.fail(central, loc + ("angles",), f"motion '{m.name}' frame {f}: "
                     f"{len(frame.angles)} angles given, the robot has {n} servos")
    if not isinstance(frame.speed, int) and len(frame.speed) != n:
        checker.fail(central, loc + ("speed",), f"motion '{m.name}' frame {f}: "
                     f"{len(frame.speed)} speeds given, the robot has {n} servos")
    for k, (angle, speed, servo) in enumerate(zip(frame.angles, frame.speeds(), servos, strict=True)):
        if not servo.min_angle <= angle <= servo.max_angle:
            checker.fail(central, loc + ("angles", k), f"motion '{m.name}' frame {f}: angle "
                         f"{angle} for servo '{servo.name}' is outside its limits "
                         f"{servo.min_angle}..{servo.max_angle}")
        if not pair_fits(angle, speed):
            where = loc + (("speed",) if isinstance(frame.speed, int) else ("speed", k))
            checker.fail(central, where, f"motion '{m.name}' frame {f}, servo "
                         f"'{servo.name}': {overflow(speed, angle)}")


def directory_rows(slots: Any) -> list[dict[str, Any]]:
    """The central board's motion directory: one row per stored motion."""
    return [{"name": s.name, "number": s.number, "frames": s.frames,
             "delay": s.delay_ticks, "offset": s.offset} for s in slots]


COMPONENT = Component(
    kind="motion", section="motions", schema=Motion, roles=("central",),
    description="the stored motions (central only)",
    unique=("name", "number"), robot_rules=robot_rules)

__all__ = ["COMPONENT", "MAX_FRAMES", "MAX_MOTIONS", "Frame", "Motion", "directory_rows",
           "image_layout", "robot_rules", "storage_rules"]
