"""Signal handlers that keep an inherited ignore: a command started as a shell's
background job (``esair std run lab &``) has SIGINT ignored, so a Ctrl-C typed for the
foreground job is not meant for it. Installing a handler over that ignore would make
the background job stop too; :func:`install` and :func:`ignored` leave it in place."""

from __future__ import annotations

import signal
import threading
import time
from typing import Any

#: the longest the main thread blocks in :func:`wait` before its handlers may run
SLICE = 0.2


def ignored(sig: int) -> bool:
    """Whether ``sig`` is ignored in this process (inherited, or set earlier)."""
    return signal.getsignal(sig) is signal.SIG_IGN


def install(sig: int, handler: Any) -> Any:
    """``signal.signal(sig, handler)`` unless ``sig`` is ignored; the previous handler
    (SIG_IGN, left as it is, when it was ignored)."""
    if ignored(sig):
        return signal.SIG_IGN
    return signal.signal(sig, handler)


def wait(event: threading.Event, timeout: float | None = None) -> bool:
    """``event.wait(timeout)`` that the main thread's signal handlers interrupt within
    :data:`SLICE` s. The kernel may hand a process's signal to any of its threads (a
    Zenoh or a host thread): the main thread, blocked in one long wait, is then not
    woken and runs the Python handler only when that wait ends."""
    end = None if timeout is None else time.monotonic() + timeout
    while True:
        left = SLICE if end is None else min(SLICE, end - time.monotonic())
        if left <= 0:
            return event.is_set()
        if event.wait(left):
            return True
