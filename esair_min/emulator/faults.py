"""Faults a user (or a test) can inject into the emulated robot."""

from __future__ import annotations

import random
from dataclasses import dataclass

from esair_min.errors import EsairError


@dataclass(frozen=True)
class Faults:
    """What goes wrong, from reset on.

    - ``actuator_nack``: the actuator board does not acknowledge (motor commands and
      frames answer/notice ``E10``);
    - ``sensor_absent``: no sensor board on the bus (``s`` answers ``E10``, the balance
      reaction sends ``!E10`` once);
    - ``corrupt_eeprom``: one byte of the motion image is flipped (``!READY image=bad``,
      ``PLY`` answers ``E09``);
    - ``noise_per_s``: random bytes injected into the board's receive line at this mean
      rate (bytes per second), drawn from a generator seeded with ``seed``;
    - ``bus_stuck``: SCL held low: every I2C transfer fails after the PIC master's
      timeout and bus clear (1.79 ms at 20 MHz), so everything on the bus answers
      ``E10`` and the image check at reset fails (``image=bad``).
    """

    actuator_nack: bool = False
    sensor_absent: bool = False
    corrupt_eeprom: bool = False
    noise_per_s: float = 0.0
    seed: int = 0
    bus_stuck: bool = False

    def __post_init__(self) -> None:
        if not self.noise_per_s >= 0:
            raise EsairError(f"noise rate {self.noise_per_s:g} must be 0 or more bytes per second")

    @property
    def any(self) -> bool:
        return (self.actuator_nack or self.sensor_absent or self.corrupt_eeprom
                or self.bus_stuck or self.noise_per_s > 0)

    def describe(self) -> str:
        parts = [name for name, on in (("actuator NACKs", self.actuator_nack),
                                       ("sensor board absent", self.sensor_absent),
                                       ("corrupt EEPROM", self.corrupt_eeprom),
                                       ("I2C bus stuck", self.bus_stuck)) if on]
        if self.noise_per_s > 0:
            parts.append(f"line noise {self.noise_per_s:g} B/s (seed {self.seed})")
        return ", ".join(parts) or "none"


def corrupt(memory: bytearray, image_len: int, rng: random.Random) -> int:
    """Flip every bit of one byte of the image body; returns its offset."""
    lo = 8 if image_len > 8 else 0
    at = rng.randrange(lo, max(image_len, lo + 1))
    memory[at] ^= 0xFF
    return at
