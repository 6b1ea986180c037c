"""Kind ``optical_flow`` (section ``flow_sensors``, central board): an ADNS-2610-class
mouse sensor on its two-wire serial port (SCLK, bidirectional SDIO; bit-banged, since
the MSSP is the I2C master). The central board reads its motion, delta x, delta y and
surface quality registers every tick, sums the deltas into a displacement in mm and
serves it with the odometry reply. Its Python behaviour (the sensor's registers and
timing) is :mod:`esair_min.components.optical_flow.core`.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import Field, StrictInt

from esair_min.components.base import Checker, Component, PinClaim
from esair_min.model.types import Name, Pin, Section

MAX_FLOW_SENSORS = 2


class FlowSensor(Section):
    """An optical-flow (mouse) sensor looking at the floor."""

    name: Name
    sclk_pin: Pin = Field(description="serial clock output")
    sdio_pin: Pin = Field(description="serial data, both ways")
    cpi: Literal[400] = Field(400, description="counts per inch (ADNS-2610: 400)")
    mount_x_mm: Annotated[StrictInt, Field(ge=-2000, le=2000)] = Field(
        description="its place in the robot's frame, forward")
    mount_y_mm: Annotated[StrictInt, Field(ge=-2000, le=2000)] = Field(
        description="its place in the robot's frame, to the left")
    mount_angle_deg: Annotated[StrictInt, Field(ge=-180, le=360)] = Field(
        0, description="its +x axis from the robot's +x axis")


def board_rules(checker: Checker, b: Any) -> None:
    if len(b.flow_sensors) > MAX_FLOW_SENSORS:
        checker.fail(b, ("flow_sensors", MAX_FLOW_SENSORS), f"at most {MAX_FLOW_SENSORS} "
                     f"flow sensors fit the odometry reply; remove "
                     f"{len(b.flow_sensors) - MAX_FLOW_SENSORS}")


def pins(f: FlowSensor) -> list[PinClaim]:
    return [PinClaim(f.sclk_pin, f"flow sensor '{f.name}' SCLK", ("sclk_pin",)),
            PinClaim(f.sdio_pin, f"flow sensor '{f.name}' SDIO", ("sdio_pin",))]


def summary(b: Any) -> list[str]:
    return ["  flow sensors: " + ", ".join(
        f"{f.name} at ({f.mount_x_mm}, {f.mount_y_mm}) mm, SCLK {f.sclk_pin} SDIO {f.sdio_pin}"
        for f in b.flow_sensors)]


COMPONENT = Component(
    kind="optical_flow", section="flow_sensors", schema=FlowSensor, roles=("central",),
    description="the optical-flow sensors (central only)",
    unique=("name",), board_rules=board_rules, pins=pins, summary=summary)
