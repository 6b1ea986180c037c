"""Keep the Python thread state of Zenoh's threads between callbacks.

Zenoh calls the bus's callbacks (``indirect=False``: bus.py) on its own Rust threads,
which Python does not know: each call takes the GIL with ``PyGILState_Ensure``, which
makes a new thread state (and its frame stack) for the call, and ``PyGILState_Release``
destroys it on return. :func:`keep`, called first in each callback, takes one more
``PyGILState_Ensure`` the first time a thread calls it and never releases it: that
thread's state then stays, and later calls only take and give back the GIL (the CPU a
callback costs: docs/std.md, "The hot path").

Through ``_ctypes`` alone: the ``ctypes`` package would cost an agent process twice
the memory. At most :data:`THREADS` threads are kept (each holds a thread state and a
16 KB frame stack until it ends): Zenoh's pools are fixed, so the cap is never reached
unless threads come and go; beyond it a callback runs as before.
"""

from __future__ import annotations

import os
import threading
from typing import Callable

THREADS = 64

# marked in the kept state itself: a thread that ends leaves its mark behind with its
# state, and a new thread with the same ident (they are reused) starts unmarked
_mark = threading.local()
_count = 0
_ensure: Callable[[], int] | None = None


def _forked() -> None:               # a forked child has none of its parent's other threads
    global _count
    _count = 0


os.register_at_fork(after_in_child=_forked)


def _load() -> Callable[[], int]:
    import _ctypes

    class _Int(_ctypes._SimpleCData):  # type: ignore[type-arg]  # C int
        _type_ = "i"

    class _PythonAPI(_ctypes.CFuncPtr):   # called with the GIL held, as ctypes.pythonapi
        _flags_ = _ctypes.FUNCFLAG_CDECL | _ctypes.FUNCFLAG_PYTHONAPI
        _restype_ = _Int

    class _Self:                          # the interpreter's own symbols
        _handle = _ctypes.dlopen(None)  # type: ignore[arg-type]  # None: the process

    fn = _PythonAPI(("PyGILState_Ensure", _Self))  # type: ignore[arg-type]  # as a CDLL
    return lambda: int(fn())


def keep() -> None:
    """Called on a Zenoh thread holding the GIL (in a callback): its thread state
    outlives this callback, once per thread."""
    global _ensure, _count
    if getattr(_mark, "kept", False) or _count >= THREADS:
        return
    if _ensure is None:
        _ensure = _load()
    _mark.kept = True
    _count += 1
    _ensure()
