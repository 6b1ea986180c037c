"""Threads that may call into Zenoh, kept so that their owner can see them end.

A Python thread inside a Zenoh (Rust, pyo3) call runs without the GIL. If the
interpreter finalizes meanwhile, the thread is ended with ``pthread_exit`` the moment
the call returns and asks for the GIL again; the forced unwind meets pyo3's
``catch_unwind`` and glibc aborts the process: "FATAL: exception not rethrown" (SIGABRT)
at the exit of a program that used the runtime as a library. A daemon thread is not
waited for at exit, so every thread of the runtime that can reach Zenoh is started
through a :class:`Threads` and joined by its owner's ``stop``/``close``, after the
session is closed (a Zenoh call on a closed session fails at once: the joins are short).
Reproducer: scripts/zenoh_exit_abort.py; docs/std.md ("Stopping a runtime used as a library").
"""

from __future__ import annotations

import threading
import time
from typing import Callable, TypeVarTuple, Unpack

_Ts = TypeVarTuple("_Ts")


class Threads:
    """Starts daemon threads and remembers those still running (finished ones leave the
    set: it stays as small as the work under way)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._live: set[threading.Thread] = set()

    def start(self, target: Callable[[Unpack[_Ts]], object], *args: Unpack[_Ts],
              name: str) -> threading.Thread:
        def run() -> None:
            try:
                target(*args)
            finally:
                with self._lock:
                    self._live.discard(t)

        t = threading.Thread(target=run, name=name, daemon=True)
        with self._lock:          # started before join() can see it (joining a thread
            self._live.add(t)     # not yet started raises RuntimeError, as when a stop()
            t.start()             # comes while a worker is being started)
        return t

    def add(self, t: threading.Thread) -> None:
        """Keep ``t`` (started elsewhere, ending on its own signal) for :meth:`join`."""
        with self._lock:
            self._live.add(t)

    def join(self, timeout: float) -> list[str]:
        """Waits up to ``timeout`` s in all for every kept thread (except the caller) to
        end; the names of those still running."""
        deadline = time.monotonic() + timeout
        me = threading.current_thread()
        with self._lock:
            threads = [t for t in self._live if t is not me]
        for t in threads:
            t.join(max(0.0, deadline - time.monotonic()))
        with self._lock:
            self._live = {t for t in self._live if t.is_alive()}
            return sorted(t.name for t in self._live if t is not me)
