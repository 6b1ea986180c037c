"""The field types every part of the board model shares: the frozen ``Section`` base and
the constrained scalars (names, pins, angles, I2C addresses). The board model
(:mod:`esair_min.model.board`) and each device kind (:mod:`esair_min.components`) build
their schemas from these, so a kind needs nothing from the board that holds it.
"""

from __future__ import annotations

from typing import Annotated, Union

from pydantic import BaseModel, ConfigDict, Field, StrictFloat, StrictInt, StrictStr

Name = Annotated[StrictStr, Field(pattern=r"^[a-z][a-z0-9_]{0,23}$",
                                  description="lower-case identifier, at most 24 chars")]
Pin = Annotated[StrictStr, Field(pattern=r"^(R[A-E][0-7]|P[B-D][0-7])$",
                                 description="port pin: RB0 (PIC18F452), PD2 (ATmega328P)")]
Angle = Annotated[StrictInt, Field(ge=0, le=999, description="servo angle, degrees")]
Speed = Annotated[StrictInt, Field(ge=0, le=25, description="speed code 0..25 (letters a..z)")]
I2cAddress = Annotated[StrictInt, Field(ge=0x08, le=0x77, description="7-bit I2C address")]
Number = Union[StrictInt, StrictFloat]


class Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, defer_build=True)
