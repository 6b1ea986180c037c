"""The options of a ``Starfish`` entry as a schema (docs/std-starfish.md): checked with
the deployment, each error at its line, and again by the driver when it opens. What needs
the room or the line (the start pose clear of walls, the odometry rate the line allows)
the driver checks once it has them."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field

from ..minlink.options import EmulateOptions

#: A finite number: an int or a float, never a bool or text.
Number = Annotated[float, Field(strict=True, allow_inf_nan=False)]
#: A number of seconds or hertz more than 0.
Positive = Annotated[float, Field(strict=True, allow_inf_nan=False, gt=0)]


class RadioOptions(BaseModel):
    """``radio:``: the radio link's range and hysteresis (m), the network device it
    switches (a simulation's own veth), and whether the audio pauses while it is down."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    device: str | None = None
    range_m: Number = 3.0
    heal_m: Number = 0.1
    pause_audio: Annotated[bool, Field(strict=True)] = True


class CameraOptions(BaseModel):
    """``camera:``: the pictures' format and the camera's field of view (degrees)."""

    model_config = ConfigDict(extra="ignore", frozen=True)

    format: Literal["png", "jpeg"] = "png"
    fov_deg: Number = 60.0


class StarfishOptions(BaseModel):
    """A ``Starfish`` entry's options (the entry's own keys, ``allow`` and ``restart``,
    are not among them)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    room_file: str
    robot: str = "starfish"
    port: str = "emulate"
    pose: Annotated[list[Number], Field(min_length=3, max_length=3)] = [1.0, 1.0, 0.0]
    odometry_hz: Positive = 10.0
    timeout: Number = 1.0
    deadline: Positive = 0.5
    snr_db: Number = 20.0
    seed: Number = 0
    echo: Number = 0.5
    radio: RadioOptions = Field(default_factory=RadioOptions)
    camera: CameraOptions = Field(default_factory=CameraOptions)
    emulate: EmulateOptions = Field(default_factory=EmulateOptions)
