"""Kind ``pressure_sensor`` (section ``sensors``): an analog sensor on the sensor board,
read by the 10-bit ADC and exposed as 2 registers (low byte, high byte) in the order of
the file. A sensor is on an ADC channel (``channel``) or on an input of the board's analog
multiplexer (``mux_input``, :mod:`esair_min.components.analog_mux`). Its C lives in
``firmware_templates/sensor``; its Python behaviour (readings from a scenario) in
:mod:`esair_min.emulator.papaman.scenario`.
"""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import Field, StrictInt

from esair_min.components.base import Checker, Component, PinClaim
from esair_min.model.hardware import ADC_PINS
from esair_min.model.types import Name, Section

MAX_SENSORS = 8


class Sensor(Section):
    """An analog sensor on the sensor board (10-bit ADC, exposed as 2 registers)."""

    name: Name
    channel: Annotated[StrictInt, Field(ge=0, le=7)] | None = Field(
        None, description="ADC channel AN0..AN7 (ADC0..ADC7); or give mux_input")
    mux_input: Annotated[StrictInt, Field(ge=0, le=7)] | None = Field(
        None, description="input of the board's mux (section mux:), 0..7; or give channel")
    group: Name = Field(description="group compared by reactions, e.g. left_foot")
    min: Annotated[StrictInt, Field(ge=0, le=1023)] = 0
    max: Annotated[StrictInt, Field(ge=0, le=1023)] = 1023


def board_rules(checker: Checker, b: Any) -> None:
    for i, s in enumerate(b.sensors):
        if s.min >= s.max:
            checker.report(b, ("sensors", i, "max"),
                           f"sensor '{s.name}': max ({s.max}) must be above min ({s.min})")


def pins(s: Sensor) -> list[PinClaim]:
    """The PIC18F452's pin of a sensor's channel (the validator claims each MCU's own);
    a sensor on a mux input claims none (the mux claims its channel)."""
    if s.channel is None:
        return []
    return [PinClaim(ADC_PINS[s.channel], f"sensor '{s.name}' (AN{s.channel})", ("channel",))]


def group_mask(sensors: tuple[Sensor, ...], group: str) -> int:
    """Bit i set for sensor i of ``group`` (the reactions' sums)."""
    return sum(1 << i for i, s in enumerate(sensors) if s.group == group)


COMPONENT = Component(
    kind="pressure_sensor", section="sensors", schema=Sensor, roles=("sensor",),
    description="the analog sensors (sensor board only, at least one)",
    unique=("name", "channel", "mux_input"), registers_per_item=2, board_rules=board_rules, pins=pins)
