"""Device kinds as components of the board model (in the manner of ESPHome's
``esphome/components/<kind>/``): one small package per kind holds

- ``SCHEMA``: the pydantic model of one item of the kind's board-file section;
- its validation rules (one board, and across the robot's boards);
- the pins it claims and the register bytes it adds to its board's I2C map;
- the rows it gives the generator's template context;
- its Python core behaviour for the emulator and harness (where it has one).

The board model (:mod:`esair_min.model.board`) builds the board file's sections from
:data:`COMPONENTS`; the validator, the generator and the emulator ask a kind through its
:class:`Component`. Imports point down: a kind imports only ``esair_min.model.types``,
``esair_min.model.hardware`` and the config layer's error helpers.
"""

from __future__ import annotations

from esair_min.components.base import Checker, Component, PinClaim
from esair_min.components import (analog_mux, dc_motor, motion, omni_base, optical_flow,
                                  pressure_sensor, servo)

#: Every device kind, in the order of the board file's sections.
COMPONENTS: tuple[Component, ...] = (servo.COMPONENT, pressure_sensor.COMPONENT, analog_mux.COMPONENT,
                                     motion.COMPONENT, dc_motor.COMPONENT,
                                     optical_flow.COMPONENT, omni_base.COMPONENT)


def component(section: str) -> Component:
    """The kind that owns the board-file section ``section`` (``servos``, ``sensors``...)."""
    for c in COMPONENTS:
        if c.section == section:
            return c
    raise KeyError(section)


__all__ = ["COMPONENTS", "Checker", "Component", "PinClaim", "component"]
