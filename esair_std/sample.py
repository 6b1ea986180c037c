"""A sensor sample as behaviors see it."""

from __future__ import annotations

from typing import Any

from .transport.codec import JSON, JSONObject


class Sample:
    """One reading: ``seq`` numbers every sample of a sensor from 1, ``t`` is
    ``time.time()`` when the sensor reported it, ``source`` the sensor's name.
    Immutable, compared by value (a plain class, not a dataclass: see esair_min's Mark)."""

    __slots__ = ("value", "seq", "t", "source")
    value: Any          # the sensor's reading, as its resource reported it (JSON)
    seq: int
    t: float
    source: str

    def __init__(self, value: JSON, seq: int, t: float, source: str):
        object.__setattr__(self, "value", value)
        object.__setattr__(self, "seq", seq)
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "source", source)

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError(f"cannot assign to field {name!r} of an immutable Sample")

    def __delattr__(self, name: str) -> None:
        raise AttributeError(f"cannot delete field {name!r} of an immutable Sample")

    def _key(self) -> tuple[object, int, float, str]:
        return (self.value, self.seq, self.t, self.source)

    def __eq__(self, other: object) -> bool:
        if type(other) is not Sample:
            return NotImplemented
        return self._key() == other._key()

    def __hash__(self) -> int:
        return hash(self._key())

    def __repr__(self) -> str:
        return (f"Sample(value={self.value!r}, seq={self.seq!r}, t={self.t!r}, "
                f"source={self.source!r})")

    def __reduce__(self) -> tuple[type[Sample], tuple[object, int, float, str]]:
        return (Sample, self._key())

    def to_wire(self) -> JSONObject:
        return {"v": self.value, "seq": self.seq, "t": self.t, "src": self.source}

    @classmethod
    def from_wire(cls, d: JSON) -> "Sample":
        """The sample :meth:`to_wire` sent; garbage raises (KeyError, ValueError)."""
        seq, t = (d["seq"], d["t"]) if isinstance(d, dict) else (None, None)
        if not isinstance(d, dict) or not isinstance(seq, (int, float, str)) \
                or not isinstance(t, (int, float, str)):
            raise ValueError(f"not a sample: {d!r}")
        return cls(d["v"], int(seq), float(t), str(d["src"]))
