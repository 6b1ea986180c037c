"""Kind ``servo``: a hobby servo on the actuator board, driven with 50 Hz PWM.

Registers: servo *m* has ``2m`` (low byte, ``angle % 100``) and ``2m+1`` (high byte,
``angle/100 + 10*speed``: the thesis's pair encoding, :mod:`esair_min.model.encoding`). Its C lives in
``firmware_templates/actuator`` (the board is made of servos); its Python behaviour in
:mod:`esair_min.emulator.papaman.actuator`.
"""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import Field, StrictInt

from esair_min.components.base import Checker, Component, PinClaim
from esair_min.model.encoding import (PAIR_HIGH_MAX, encode_high, encode_pair,
                                      max_speed_at, pair_fits)
from esair_min.model.types import Angle, Name, Pin, Section, Speed

MAX_SERVOS = 16


class Servo(Section):
    """A hobby servo on the actuator board (50 Hz PWM)."""

    name: Name
    index: Annotated[StrictInt, Field(ge=0, lt=MAX_SERVOS)] = Field(
        description="motor number: letter a = 0; registers 2*index, 2*index+1")
    pin: Pin
    min_angle: Angle
    max_angle: Angle
    stand_angle: Angle
    default_speed: Speed = 0
    pulse_min_us: Annotated[StrictInt, Field(ge=200, le=3000)] = Field(
        500, description="pulse width at 0 degrees")
    pulse_max_us: Annotated[StrictInt, Field(ge=200, le=3000)] = Field(
        2500, description="pulse width at 180 degrees")


def overflow(speed: int, angle: int) -> str:
    """Why a speed/angle pair does not fit the high byte, and what would."""
    return (f"speed {speed} with angle {angle} encodes to high byte "
            f"{encode_high(angle, speed)} (angle/100 + 10*speed), more than "
            f"{PAIR_HIGH_MAX}; at this angle use a speed of at most {max_speed_at(angle)}")


def board_rules(checker: Checker, b: Any) -> None:
    checker.rule(_index_rules, checker, b)
    for i in range(len(b.servos)):
        checker.rule(_servo_rules, checker, b, i)


def _index_rules(checker: Checker, b: Any) -> None:
    for i, s in enumerate(sorted(b.servos, key=lambda s: s.index)):
        if s.index != i:
            checker.fail(b, ("servos", b.servos.index(s), "index"),
                         f"servo '{s.name}': index {s.index} leaves a gap; servo indices "
                         f"must run 0..{len(b.servos) - 1} and index {i} is missing")


def _servo_rules(checker: Checker, b: Any, i: int) -> None:
    s = b.servos[i]
    if s.min_angle > s.max_angle:
        checker.fail(b, ("servos", i, "max_angle"), f"servo '{s.name}': max_angle "
                     f"({s.max_angle}) is below min_angle ({s.min_angle})")
    if not s.min_angle <= s.stand_angle <= s.max_angle:
        checker.fail(b, ("servos", i, "stand_angle"), f"servo '{s.name}': stand_angle "
                     f"{s.stand_angle} is outside its limits {s.min_angle}..{s.max_angle}")
    if s.pulse_min_us >= s.pulse_max_us:
        checker.fail(b, ("servos", i, "pulse_max_us"), f"servo '{s.name}': pulse_max_us "
                     f"({s.pulse_max_us}) must be above pulse_min_us ({s.pulse_min_us})")
    if not pair_fits(s.stand_angle, s.default_speed):
        checker.fail(b, ("servos", i, "default_speed"), f"servo '{s.name}': default "
                     f"{overflow(s.default_speed, s.stand_angle)}")


def pins(s: Servo) -> list[PinClaim]:
    return [PinClaim(s.pin, f"servo '{s.name}'", ("pin",))]


def limit_rows(servos: tuple[Servo, ...]) -> list[dict[str, Any]]:
    """The central board's view of each servo: limits, stand pose, speed at reset."""
    return [{"name": s.name, "index": s.index, "min": s.min_angle, "max": s.max_angle,
             "stand": s.stand_angle, "speed": s.default_speed} for s in servos]


def initial_registers(servos: tuple[Servo, ...]) -> bytes:
    """The actuator's register map at reset: every servo at its stand pose."""
    return bytes(b for s in servos for b in encode_pair(s.stand_angle, s.default_speed))


COMPONENT = Component(
    kind="servo", section="servos", schema=Servo, roles=("actuator",),
    description="the servos (actuator only, at least one)",
    unique=("name", "index"), registers_per_item=2, board_rules=board_rules, pins=pins)
