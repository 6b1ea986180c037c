"""Behavior: the user's deliberative component (thesis 3.4).

A subclass sets ``period`` (seconds between ``step()`` calls; ``None``: ``run()`` once)
and overrides the life-cycle methods it needs. It reaches resources only through
registration + the Sensor/Actuator Connections (``attach_sensor``/``attach_actuator``)
and other behaviors only through the Behavior Supervisor (``put``/``get``/``state``).
The runtime builds the object and calls every method on the behavior's own thread
(thread mode) or in its own process (process mode): the same code runs in both.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Any, cast

if TYPE_CHECKING:  # pragma: no cover
    from typing import Protocol

    from .connections import ActuatorHandle, SensorHandle
    from .spec import Spec
    from .transport.codec import JSON

    class _Host(Protocol):
        """What a component reaches through its host (hosts/behavior_host.py's hosts)."""
        name: str
        spec: Spec
        stopping: bool
        busy: bool
        enabled: bool

        def attach_sensor(self, name: str, keep: int) -> SensorHandle: ...
        def attach_actuator(self, name: str) -> ActuatorHandle: ...
        def register(self, resource: str, level: str) -> str: ...
        def configure(self, resource: str, key: str, value: JSON) -> JSON: ...
        def put(self, name: str, data: JSON, timeout: float) -> bool: ...
        def get(self, name: str, timeout: float) -> JSON: ...
        def state_of(self, name: str) -> str | None: ...
        def set_reaction(self, name: str, enabled: bool) -> None: ...
        def direct(self, name: str) -> SensorHandle | ActuatorHandle: ...
        def stop_robot(self, reason: str) -> None: ...

STATES = ("starting", "running", "busy", "stopped", "failed")


class _Hosted:
    """What a component with a host of its own shares (behaviors, reactions, drivers):
    name, options, log."""

    # the host (set by the runtime before __init__)
    _esair: _Host = None  # type: ignore[assignment]  # None only until the runtime sets it

    @property
    def name(self) -> str:
        return self._esair.name

    @property
    def options(self) -> dict[str, Any]:
        return self._esair.spec.options

    @property
    def log(self) -> logging.Logger:
        return logging.getLogger(f"esair_std.{self._esair.name}")


class _Component(_Hosted):
    """What behaviors and reactions share: name, options, log, the host link."""

    period: float | None = None
    deadline: float | None = None   # seconds one call may take; None: 10 x period, >= 1 s

    @property
    def stopping(self) -> bool:
        """True once the runtime asked this component to stop (a long run() checks it)."""
        return self._esair.stopping

    # life cycle (override what you need)
    def start(self) -> None:
        """Called once on the component's thread before the first step."""

    def step(self) -> None:
        """Called every ``period`` seconds; must return quickly."""

    def stop(self) -> None:
        """Called once when the component is removed or the runtime stops."""

    def detached(self, resource: str) -> None:
        """The resource was removed; its handle no longer works (the component runs on)."""

    def robot_stopped(self, by: str, reason: str) -> None:
        """The robot was STOPPED (docs/std.md, "The latched stop"): every actuator
        command is refused until an operator releases it. Drop the motions you queued:
        the release starts nothing, so nothing queued should play on after it."""

    def robot_released(self, by: str) -> None:
        """An operator released the STOP: commands are taken again."""

    def stop_robot(self, reason: str = "") -> None:
        """STOP the robot (latched, as ``esair std stop``): allowed only to a behavior
        whose deployment entry says ``may_stop: true``; raises Refused otherwise."""
        self._esair.stop_robot(reason)


class Behavior(_Component):
    """Base class of user behaviors (see the module docstring and docs/std.md)."""

    def run(self) -> None:
        """With ``period = None``: called once after start(); the behavior is ``busy``
        (takes no data) until it returns, then it serves puts and gets until removed."""

    def receive(self, sender: str, data: Any) -> None:
        """The BS delivers another behavior's ``put(self.name, data)``."""

    def provide(self, requester: str) -> object:
        """The BS asks for data on another behavior's ``get(self.name)``."""
        return None

    # resources: registration with the RS, then the SC / AC
    def attach_sensor(self, name: str, keep: int = 64) -> "SensorHandle":
        """Register for ``read`` and attach through the SC. ``keep`` bounds the samples
        kept between two ``samples()`` calls (older ones are overwritten and counted).
        Raises Refused with the reason."""
        return self._esair.attach_sensor(name, keep)

    def attach_actuator(self, name: str) -> "ActuatorHandle":
        """Register for ``command`` and attach through the AC. Raises Refused."""
        return self._esair.attach_actuator(name)

    def register(self, resource: str, level: str = "read") -> str:
        """Register with the RS for ``level`` (read, command, configure) without attaching;
        attach_* register for you. Raises Refused with the reason."""
        return self._esair.register(resource, level)

    def configure(self, resource: str, key: str, value: object) -> Any:
        """ioctl-like setting, checked by the RS (needs a registration at ``configure``)."""
        # JSON, checked where it is encoded (else TransportError)
        return self._esair.configure(resource, key, cast("JSON", value))

    # other behaviors, through the BS
    def put(self, name: str, data: object, timeout: float = 1.0) -> bool:
        """Deliver ``data`` to behavior ``name``; False (counted, logged) on failure."""
        # JSON, checked where it is copied or encoded (else the put fails: False)
        return self._esair.put(name, cast("JSON", data), timeout)

    def get(self, name: str, timeout: float = 1.0) -> Any:
        """Ask behavior ``name`` for data (its ``provide()``); None (counted) on failure."""
        return self._esair.get(name, timeout)

    def state(self, name: str) -> str | None:
        """Any component's state (None: no such component)."""
        return self._esair.state_of(name)

    def enable_reaction(self, name: str) -> None:
        self._esair.set_reaction(name, True)

    def disable_reaction(self, name: str) -> None:
        self._esair.set_reaction(name, False)

    @property
    def busy(self) -> bool:
        return self._esair.busy

    @busy.setter
    def busy(self, value: bool) -> None:
        """True: state ``busy`` (puts and gets are refused, the BS retries)."""
        self._esair.busy = bool(value)
