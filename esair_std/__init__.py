"""ESAIR STD: the host runtime (thesis 3.4) — behaviors and resources, joined by the
Behavior and Resource Supervisors and the Sensor and Actuator Connections, in thread
mode or in process mode on Eclipse Zenoh. See docs/std.md.

The names below are the stable public API.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .behavior import Behavior
from .errors import CommandError, Refused, ResourceLost, StdError
from .level import Level
from .reaction import Reaction
from .resource import Actuator, Driver, Sensor
from .sample import Sample

if TYPE_CHECKING:  # pragma: no cover
    from .runtime import Runtime

__all__ = ["Behavior", "Reaction", "Sensor", "Actuator", "Driver", "Refused", "Runtime",
           "Sample", "CommandError", "ResourceLost", "Level", "StdError"]


def __getattr__(name: str) -> type[Runtime]:
    # Runtime pulls in the supervisors (and, given a path or a dict, the deployment
    # loader's pydantic): loaded only when asked for, so that an agent process hosting
    # one component stays small.
    if name == "Runtime":
        from .runtime import Runtime
        return Runtime
    raise AttributeError(name)
