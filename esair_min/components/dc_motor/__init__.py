"""Kind ``dc_motor`` (section ``motors``, drive board): a wheel's DC motor driven with a
PWM duty on one pin and its direction on another.

A PIC18F452 has two CCP modules, whose PWM outputs are fixed pins (CCP1 on RC2, CCP2
on RC1); the ATmega328P's drive port has four (OC0A on PD6, OC0B on PD5, OC1A on PB1,
OC1B on PB2; Timer2's OC2A/OC2B are not PWM outputs there: Timer2 is the port's
interrupt). Every other motor gets software PWM from the drive board's timer interrupt.
The units per part are :attr:`esair_min.model.mcu.McuSpec.drive_pwm`. ``pwm: auto``
picks by the pin, and :func:`pwm_units` says which wheel got which (``esair check``
prints it). The drive board's register map holds each motor's wanted speed
(2 bytes, signed mm/s at the rim, low byte first); the board ramps toward it
(``ramp_mm_s2``) and never drives a motor above its ``limit_mm_s``. Its Python
behaviour is :mod:`esair_min.components.dc_motor.core`.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

from pydantic import Field, StrictBool, StrictInt

from esair_min.components.base import Checker, Component, PinClaim
from esair_min.components.dc_motor.core import SOFT_PWM_ISR_HZ
from esair_min.model.avr import timer2_ctc
from esair_min.model.mcu import McuSpec
from esair_min.model.types import Name, Pin, Section

MAX_MOTORS = 6


class DcMotor(Section):
    """A DC wheel motor: PWM duty on one pin, direction on another."""

    name: Name
    index: Annotated[StrictInt, Field(ge=0, lt=MAX_MOTORS)] = Field(
        description="wheel number; registers 2*index (low), 2*index+1 (high)")
    pwm_pin: Pin = Field(description="the PWM output (PIC18F452: RC2 = CCP1, RC1 = CCP2; "
                                     "ATmega328P: PD6 = OC0A, PD5 = OC0B, PB1 = OC1A, PB2 = "
                                     "OC1B; others: software)")
    dir_pin: Pin = Field(description="the direction output: high = forward")
    pwm: Literal["auto", "ccp1", "ccp2", "oc0a", "oc0b", "oc1a", "oc1b", "oc2a", "oc2b",
                 "software"] = Field(
        "auto", description="which PWM unit drives it; auto: by the pin")
    reverse: StrictBool = Field(False, description="the motor is wired backwards")
    wheel_radius_mm: Annotated[StrictInt, Field(ge=5, le=200)] = Field(
        description="the wheel's radius")
    max_rpm: Annotated[StrictInt, Field(ge=1, le=30000)] = Field(
        description="wheel revolutions per minute at full duty")
    mount_angle_deg: Annotated[StrictInt, Field(ge=-180, le=360)] = Field(
        description="where the wheel sits around the robot's centre, from its +x axis")
    mount_radius_mm: Annotated[StrictInt, Field(ge=10, le=2000)] = Field(
        description="distance of the wheel from the robot's centre")
    limit_mm_s: Annotated[StrictInt, Field(ge=1, le=9999)] = Field(
        description="the largest rim speed it may be driven at")
    ramp_mm_s2: Annotated[StrictInt, Field(ge=1, le=100000)] = Field(
        2000, description="the largest change of its speed per second")

    @property
    def full_speed_mm_s(self) -> float:
        """Rim speed at full duty."""
        return 2 * math.pi * self.wheel_radius_mm * self.max_rpm / 60


def pwm_unit(m: DcMotor, spec: McuSpec) -> str:
    """A unit of ``spec.drive_pwm`` or ``software``: what drives motor ``m`` on that MCU
    (``auto`` resolved by the pin; the validator has refused a unit the part lacks)."""
    if m.pwm != "auto":
        return m.pwm
    return next((unit for unit, pin in spec.drive_pwm.items() if pin == m.pwm_pin), "software")


def pwm_units(motors: tuple[DcMotor, ...], spec: McuSpec) -> dict[str, str]:
    return {m.name: pwm_unit(m, spec) for m in motors}


def motor_units(motors: tuple[DcMotor, ...], spec: McuSpec) -> list[tuple[DcMotor, str, int]]:
    """Each motor by index with its unit and, on software PWM, its number among those
    (the ports' ``soft_duty<k>``; -1 for a hardware unit)."""
    out = []
    soft = 0
    for m in sorted(motors, key=lambda m: m.index):
        unit = pwm_unit(m, spec)
        out.append((m, unit, soft if unit == "software" else -1))
        soft += unit == "software"
    return out


def _units_help(spec: McuSpec) -> str:
    return ", ".join(f"{u.upper()} ({p})" for u, p in spec.drive_pwm.items())


def board_rules(checker: Checker, b: Any) -> None:
    checker.rule(_index_rules, checker, b)
    spec: McuSpec = b.spec
    units = spec.drive_pwm
    if b.motors and spec.family == "avr" and timer2_ctc(b.mcu.clock_hz, SOFT_PWM_ISR_HZ) is None:
        checker.report(b, ("mcu", "clock_hz"), f"the {spec.name} drive port's Timer2 cannot "
                       f"interrupt exactly {SOFT_PWM_ISR_HZ} times a second at "
                       f"{b.mcu.clock_hz} Hz (the software PWM step and the control tick); "
                       "use a clock_hz it can divide down to that, e.g. 8000000, 16000000 "
                       "or 20000000")
    for i, m in enumerate(b.motors):
        loc = ("motors", i, "pwm")
        if m.pwm in spec.drive_pwm_taken:
            pin, timer = spec.drive_pwm_taken[m.pwm]
            checker.report(b, loc, f"motor '{m.name}': {m.pwm.upper()} ({pin}) is on {timer}, "
                           f"which the {spec.name} drive port takes for its interrupt (software "
                           f"PWM and the control tick); use {_units_help(spec)} or pwm: software")
        elif m.pwm not in ("auto", "software") and m.pwm not in units:
            checker.report(b, loc, f"motor '{m.name}': the {spec.name} has no {m.pwm.upper()}; "
                           f"its hardware PWM outputs are {_units_help(spec)}, or use pwm: "
                           "software")
        elif m.pwm in units and m.pwm_pin != units[m.pwm]:
            checker.report(b, ("motors", i, "pwm_pin"),
                           f"motor '{m.name}': {m.pwm.upper()} drives pin {units[m.pwm]} "
                           f"on the {b.mcu.part}, not {m.pwm_pin}; set pwm_pin: "
                           f"{units[m.pwm]} or pwm: software")
        if m.limit_mm_s > m.full_speed_mm_s:
            checker.report(b, ("motors", i, "limit_mm_s"),
                           f"motor '{m.name}': limit_mm_s {m.limit_mm_s} is above its full "
                           f"speed ({m.full_speed_mm_s:.0f} mm/s at {m.max_rpm} rpm with a "
                           f"{m.wheel_radius_mm} mm wheel); lower the limit")


def _index_rules(checker: Checker, b: Any) -> None:
    for i, m in enumerate(sorted(b.motors, key=lambda m: m.index)):
        if m.index != i:
            checker.fail(b, ("motors", b.motors.index(m), "index"),
                         f"motor '{m.name}': index {m.index} leaves a gap; motor indices "
                         f"must run 0..{len(b.motors) - 1} and index {i} is missing")


def pins(m: DcMotor) -> list[PinClaim]:
    return [PinClaim(m.pwm_pin, f"motor '{m.name}' PWM", ("pwm_pin",)),
            PinClaim(m.dir_pin, f"motor '{m.name}' direction", ("dir_pin",))]


def summary(b: Any) -> list[str]:
    units = pwm_units(b.motors, b.spec)
    return ["  motors: " + ", ".join(
        f"{m.name} {units[m.name].upper() if units[m.name] != 'software' else 'software PWM'}"
        f" ({m.pwm_pin})" for m in b.motors)]


COMPONENT = Component(
    kind="dc_motor", section="motors", schema=DcMotor, roles=("drive",),
    description="the wheel motors (drive board only, at least one)",
    unique=("name", "index"), registers_per_item=2, board_rules=board_rules, pins=pins,
    summary=summary)
