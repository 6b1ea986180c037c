"""Reaction: resident, simple, immediate (thesis 3.4). Its resources are fixed in the
deployment and it reaches them directly — no registration, no SC/AC. Behaviors may
disable and enable it; while disabled its ``step()`` is not called."""

from __future__ import annotations

from typing import Any

from .behavior import _Component


class Reaction(_Component):
    period: float | None = 0.01

    def resource(self, name: str) -> Any:
        """The driver-level handle of one of this reaction's resources: a SensorHandle
        (``latest()``, ``samples()``) or an ActuatorHandle (``send()``)."""
        return self._esair.direct(name)

    @property
    def enabled(self) -> bool:
        return self._esair.enabled
