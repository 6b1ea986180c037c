"""The emulated robot: three boards on a virtual I2C bus behind a virtual serial port.

Importing this package registers the ``esair://`` URL scheme with pySerial, so that
``serial.serial_for_url("esair://boards/papaman")`` talks to an in-process emulator
(see :mod:`.protocol_esair` and docs/emulator.md).
"""

from __future__ import annotations

import serial as _serial

from esair_min.emulator.clock import VirtualClock
from esair_min.emulator.faults import Faults
from esair_min.emulator.papaman.robot_sim import Emulator
from esair_min.emulator.papaman.scenario import Scenario, load_scenario, resolve_scenario

if __name__ not in _serial.protocol_handler_packages:
    _serial.protocol_handler_packages.append(__name__)

__all__ = ["Emulator", "Faults", "Scenario", "VirtualClock", "load_scenario",
           "resolve_scenario"]
