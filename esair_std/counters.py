"""Named counters that several threads add to (a host's transport threads and its
worker, the RS's and the agent's), each update atomic.

``c["x"] += 1`` on a plain dict is a read, an add and a write: two threads doing it at
once may lose one of the two. :meth:`Counters.add` does all three under the object's
lock; reads (``c["x"]``, ``dict(c)``) see whole numbers, and :meth:`snapshot` every
counter as of one moment.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator, Mapping


class Counters(Mapping[str, int]):
    """``Counters(a=0, b=0)``: a mapping of counters, changed by :meth:`add` (and
    :meth:`set` / ``c[key] = value`` for a counter copied from elsewhere). A counter
    never added reads 0 (as in :class:`collections.Counter`), and is not ``in`` it."""

    __slots__ = ("_c", "_lock")

    def __init__(self, **start: int):
        self._c: dict[str, int] = dict(start)
        self._lock = threading.Lock()

    def add(self, key: str, n: int = 1) -> None:
        """``n`` more of ``key`` (a counter not yet known starts at 0)."""
        with self._lock:
            self._c[key] = self._c.get(key, 0) + n

    def __setitem__(self, key: str, value: int) -> None:
        with self._lock:
            self._c[key] = value

    set = __setitem__

    def update(self, **values: int) -> None:
        with self._lock:
            self._c.update(values)

    def snapshot(self) -> dict[str, int]:
        """Every counter as of one moment."""
        with self._lock:
            return dict(self._c)

    def __getitem__(self, key: str) -> int:
        return self._c.get(key, 0)

    def __contains__(self, key: object) -> bool:
        return key in self._c

    def __iter__(self) -> Iterator[str]:
        return iter(self.snapshot())

    def __len__(self) -> int:
        return len(self._c)

    def __repr__(self) -> str:
        return f"Counters({self.snapshot()!r})"
