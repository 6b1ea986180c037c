"""Kind ``analog_mux`` (section ``mux``, at most one per sensor board): an 8:1 analog
multiplexer of the 74HC4051 / CD4051 class ahead of one ADC channel. Its common output
(Z, COM) is wired to ``channel``; its select inputs S0, S1, S2 to the MCU's ``select``
pins (S0 first; a 4:1 or 2:1 mux has two or one). Sensors with ``mux_input: n``
(:mod:`esair_min.components.pressure_sensor`) are read by writing n's bits to the select
pins, waiting ``settle_us`` and converting ``channel``: more sensors than the MCU has
free analog channels (papaman-avr's eight feet on an ATmega328P whose TWI takes ADC4/ADC5).

Pins: the select pins are claimed here; the common channel's pin depends on the MCU and
is claimed by the validator with the sensors' channels.
"""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import Field, StrictInt

from esair_min.components.base import Checker, Component, PinClaim
from esair_min.model.types import Pin, Section

#: Select pins of the largest mux (S0..S2): 8 inputs.
MAX_SELECT = 3


class Mux(Section):
    """An analog multiplexer (74HC4051 / CD4051 class) on one ADC channel."""

    channel: Annotated[StrictInt, Field(ge=0, le=7)] = Field(
        description="the ADC channel its common output (Z / COM) is wired to")
    select: Annotated[tuple[Pin, ...], Field(min_length=1, max_length=MAX_SELECT)] = Field(
        description="the MCU pins wired to its select inputs, S0 first (3 for an 8:1 mux: "
                    "input n is selected by n's bits)")
    settle_us: Annotated[StrictInt, Field(ge=0, le=10000)] = Field(
        10, description="time from a select change to a settled output (switching time and "
                        "the source's RC), in us: the firmware waits it before converting")

    @property
    def inputs(self) -> int:
        """How many inputs the select pins reach (8 with three)."""
        return 1 << len(self.select)


def select_name(i: int) -> str:
    return f"S{i}"


def pins(m: Mux) -> list[PinClaim]:
    return [PinClaim(pin, f"the mux's select {select_name(i)}", ("select", i))
            for i, pin in enumerate(m.select)]


def board_rules(checker: Checker, b: Any) -> None:
    """Each sensor names an ADC channel or an input of the mux, one of the two; an input
    the select pins reach; a declared mux has a sensor."""
    m = b.mux
    for i, s in enumerate(b.sensors):
        if s.channel is not None and s.mux_input is not None:
            checker.report(b, ("sensors", i, "mux_input"), f"sensor '{s.name}' has a "
                           f"'channel' and a 'mux_input': give one (channel: an ADC channel; "
                           f"mux_input: an input of the board's mux)", key=True)
        elif s.channel is None and s.mux_input is None:
            checker.report(b, ("sensors", i), f"sensor '{s.name}' needs 'channel' (an ADC "
                           f"channel) or 'mux_input' (an input of the board's mux)")
        elif s.mux_input is not None and m is None:
            checker.report(b, ("sensors", i, "mux_input"), f"sensor '{s.name}': mux_input "
                           f"{s.mux_input} needs a 'mux:' section on this board (its ADC "
                           f"channel and select pins)")
        elif s.mux_input is not None and m is not None and s.mux_input >= m.inputs:
            checker.report(b, ("sensors", i, "mux_input"), f"sensor '{s.name}': the mux has "
                           f"inputs 0..{m.inputs - 1} ({len(m.select)} select pins), not "
                           f"{s.mux_input}; add select pins (S0..S{MAX_SELECT - 1}) or use "
                           f"another input")
    if m is not None and not any(s.mux_input is not None for s in b.sensors):
        checker.report(b, ("mux",), "the mux has no sensor: give sensors a 'mux_input', or "
                       "remove 'mux:'", key=True)


def summary(b: Any) -> list[str]:
    m = b.mux
    if m is None:
        return []
    used = sum(s.mux_input is not None for s in b.sensors)
    adc = "ADC" if b.spec.family == "avr" else "AN"
    return [f"  mux: {used} of {m.inputs} inputs on {adc}{m.channel}, select "
            f"{', '.join(m.select)} (S0 first), settling {m.settle_us} us"]


COMPONENT = Component(
    kind="analog_mux", section="mux", schema=Mux, roles=("sensor",), many=False,
    description="optional: an analog multiplexer (74HC4051 class) on one ADC channel; "
                "sensors with 'mux_input' are read through it",
    board_rules=board_rules, pins=pins, summary=summary)
