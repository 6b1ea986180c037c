"""A sensor sample as behaviors see it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Sample:
    """One reading: ``seq`` numbers every sample of a sensor from 1, ``t`` is
    ``time.time()`` when the sensor reported it, ``source`` the sensor's name."""

    value: Any
    seq: int
    t: float
    source: str

    def to_wire(self) -> dict:
        return {"v": self.value, "seq": self.seq, "t": self.t, "src": self.source}

    @classmethod
    def from_wire(cls, d: dict) -> "Sample":
        return cls(d["v"], int(d["seq"]), float(d["t"]), str(d["src"]))
