"""Sensor, Actuator and Driver: the agents of a driver (thesis 3.4).

The runtime calls ``open()`` before use and ``close()`` at removal, on the resource's
own host thread (thread mode) or process (process mode). A Sensor either sets
``rate_hz`` (``read()`` is polled at that rate; returning None reports nothing) or
calls ``self.report(value)`` itself (from any thread). An Actuator's ``write(command)``
runs for each command; its return value is the sender's ``send()`` result, an
exception raised in it reaches the sender as CommandError. A Driver provides several
resources (``resources()``), named ``<entry>.<child>`` in the deployment.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Any

from .behavior import _Hosted

if TYPE_CHECKING:  # pragma: no cover
    from typing import Protocol

    class _Slot(Protocol):
        """What a resource reaches through its slot (hosts/resource_host.py)."""
        name: str
        options: dict[str, object]
        host: Any          # the resource's host: a driver's children reach their own driver

        def report(self, value: object) -> None: ...
        def set_state(self, state: str, reason: str) -> None: ...
from .errors import CommandError


class _Agent:
    # the host's slot for this resource (set by the runtime)
    _esair: _Slot = None  # type: ignore[assignment]  # None only until the runtime sets it
    #: The keys configure() takes, listed by its "no setting" error (no_setting()).
    settings: tuple[str, ...] = ()

    @property
    def name(self) -> str:
        return self._esair.name

    @property
    def options(self) -> dict[str, Any]:
        return self._esair.options

    @property
    def log(self) -> logging.Logger:
        return logging.getLogger(f"esair_std.{self._esair.name}")

    def open(self) -> None:
        """Acquire the device. Raising here makes the resource fail to deploy."""

    def close(self) -> None:
        """Release the device."""

    def mark_lost(self, reason: str) -> None:
        """The device is gone: state ``lost``; commands fail at once with ResourceLost."""
        self._esair.set_state("lost", reason)

    def mark_ready(self) -> None:
        self._esair.set_state("ready", "")

    def no_setting(self, key: str) -> CommandError:
        """The error for a key configure() does not take, listing ``settings``:
        ``arm: no setting 'gain' (settings: speed)``; raise it."""
        if self.settings:
            listed = "settings: " + ", ".join(self.settings)
        elif getattr(type(self), "configure", None) in (Sensor.configure, Actuator.configure):
            listed = "it has no settings"
        else:                       # configure() overridden, its keys not declared
            listed = "its class declares no settings"
        return CommandError(self.name, f"no setting {key!r} ({listed})")


class Sensor(_Agent):
    rate_hz: float | None = None
    settings: tuple[str, ...] = ("rate_hz",)

    def read(self) -> object:
        """Polled at ``rate_hz``; the value returned is reported (None: nothing)."""
        return None

    def report(self, value: object) -> None:
        """Report one sample now (numbered, time-stamped, routed by the SC)."""
        self._esair.report(value)

    def configure(self, key: str, value: Any) -> object:
        if key == "rate_hz":
            self.rate_hz = float(value)
            return self.rate_hz
        raise self.no_setting(key)


class Actuator(_Agent):
    def write(self, command: Any) -> object:
        raise CommandError(self.name, "write() is not implemented")

    def halt(self) -> object:
        """The robot is STOPPED (docs/std.md, "The latched stop"): stop moving now
        (send your device's stop; a wheel to zero). Called once per STOP from the
        runtime's thread, not the host's: while a write() may still run; keep it short.
        Default: nothing (an actuator that does not move by itself). What it returns,
        if not None, is recorded as the answer to the command ``"stop"`` (recordings,
        the HMI's pose). Every write() is refused until the release; release() follows."""

    def release(self) -> None:
        """The STOP was released: commands are taken again (starts nothing)."""

    def configure(self, key: str, value: Any) -> object:
        raise self.no_setting(key)


class Driver(_Hosted):
    """One device link giving several resources; one host (thread or process) for all."""

    def open(self) -> None:
        """Open the link (before resources())."""

    def resources(self) -> dict[str, "Sensor | Actuator"]:
        """The child resources: ``{child_name: Sensor() or Actuator()}``."""
        return {}

    def close(self) -> None:
        """Close the link (after every child's close())."""

    def halt(self) -> None:
        """The robot is STOPPED: as Actuator.halt(), for the whole link (called before
        the children's)."""

    def release(self) -> None:
        """The STOP was released (starts nothing)."""
