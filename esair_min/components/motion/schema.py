"""The board-file schema of kind ``motion``: a motion and its frames."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field, StrictInt

from esair_min.model.types import Angle, Name, Section, Speed

MAX_MOTIONS = 100
MAX_FRAMES = 255


class Frame(Section):
    """One pose: an angle per servo (by index) and a speed (one, or one per servo)."""

    angles: tuple[Angle, ...]
    speed: Speed | tuple[Speed, ...] = 0

    def speeds(self) -> tuple[int, ...]:
        if isinstance(self.speed, int):
            return (self.speed,) * len(self.angles)
        return self.speed


class Motion(Section):
    """A stored motion: frames played one per tick group from the EEPROM."""

    name: Name
    number: Annotated[StrictInt, Field(ge=0, lt=MAX_MOTIONS)] = Field(
        description="the nn of PLYnn")
    delay_ticks: Annotated[StrictInt, Field(ge=1, le=255)] = Field(
        1, description="ticks from one frame's write to the next")
    frames: Annotated[tuple[Frame, ...], Field(min_length=1, max_length=MAX_FRAMES)]
