"""The options of a ``MinLink`` entry as a schema (docs/std-papaman.md): checked with the
deployment (``esair std check``, ``esair std run``), so that a bad option is reported at
its line like every other deployment error, and again by the driver when it opens (an
entry added at run time has no file)."""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field

from .budget import DEFAULT_DEADLINE_S, DEFAULT_FEET_SHARE

#: ``s`` polls per second when ``feet_hz`` is not given.
DEFAULT_FEET_HZ = 8.0

#: A number of the options: an int or a float, never a bool or text.
Number = Annotated[float, Field(strict=True)]


class RestartPolicy(BaseModel):
    """``emulate: {restart: {max: N, within: T}}``: the emulated robot restarted at most N
    times in any T seconds (esair_std/restart_window.py); none by default."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    max: Annotated[int, Field(strict=True, ge=0)] = 0
    within: Annotated[float, Field(strict=True, ge=0)] = 0.0


class EmulateOptions(BaseModel):
    """``emulate:``: the driver's restart policy, and every other key an ``esair emulate``
    option of the child (``scenario: push`` -> ``--scenario push``)."""

    model_config = ConfigDict(extra="allow", frozen=True)

    restart: RestartPolicy = Field(default_factory=RestartPolicy)

    def args(self) -> dict[str, object]:
        """The child's options (every key but ``restart``)."""
        return dict(self.model_extra or {})


class MinLinkOptions(BaseModel):
    """A ``MinLink`` entry's options; the entry's own keys (``allow``, ``restart``) and
    the runtime's (``rate_hz``) are not the driver's and pass unread."""

    model_config = ConfigDict(extra="ignore", frozen=True)

    robot: str | None = None
    port: Annotated[str, Field(strict=True, min_length=1)]
    emulate: EmulateOptions = Field(default_factory=EmulateOptions)
    feet_hz: Number = DEFAULT_FEET_HZ
    feet_share: Number = DEFAULT_FEET_SHARE
    timeout: Number | None = None      # None: 1 s, or 3 s for port: emulate (driver.py)
    deadline: Annotated[float, Field(strict=True, gt=0)] = DEFAULT_DEADLINE_S
    duplex: Annotated[bool, Field(strict=True)] = True
