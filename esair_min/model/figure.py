"""The optional ``figure:`` section of an actuator board: how a person's screen draws
the robot (docs/board-format.md, "figure"). Today one kind, ``biped``: PAPA-MAN's stick
figure, front and side, drawn by the HMI (docs/hmi.md) from the link lengths and the
servo that turns each joint about its axis. Without the section the HMI shows the joints
as dials. Nothing on the robot reads it."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, StrictInt

from esair_min.model.types import Name, Number, Section

#: The joints of one biped leg, hip to ankle: the joint and the axis it turns about.
LEG_JOINTS = ("hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll")
LINKS = ("torso", "hip", "thigh", "shank", "foot")

Length = Annotated[Number, Field(gt=0, le=10_000, description="millimetres")]


class Links(Section):
    """Link lengths in millimetres."""

    torso: Length = Field(description="hip axis to the top of the torso")
    hip: Length = Field(description="half the distance between the two hip joints")
    thigh: Length = Field(description="hip pitch axis to knee axis")
    shank: Length = Field(description="knee axis to ankle axis")
    foot: Length = Field(description="ankle axis to the sole")


class Leg(Section):
    """The servo that turns each joint of one leg (each a servo of this board). The
    joint's name is its axis: yaw about the vertical, roll about the walking direction,
    pitch (and the knee) about the line through both hips."""

    hip_yaw: Name
    hip_roll: Name
    hip_pitch: Name
    knee: Name
    ankle_pitch: Name
    ankle_roll: Name


class Figure(Section):
    """How the HMI draws the robot (optional; without it: the joints as dials)."""

    kind: Literal["biped"] = Field(description="the drawing: biped (two legs of six joints)")
    links_mm: Links
    legs: dict[Literal["left", "right"], Leg] = Field(
        description="left and right: the servo of each joint")
    reversed: tuple[Name, ...] = Field(
        (), description="servos whose angle grows against the figure's positive turn")
    zero: dict[Name, Annotated[StrictInt, Field(ge=0, le=999)]] = Field(
        {}, description="a servo's angle where its joint is straight (default: its stand_angle)")
