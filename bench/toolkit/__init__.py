"""What the benches repeat, and what the benches and the tests both use: the checkout's
folders, a free local port or Zenoh endpoint (never 7447), a condition waited for, the
headless Chromium's command line, and a ratio printed the one way every bench prints it.
Its modules: ``netstd`` (ESAIR STD's processes in network namespaces), ``zpeer`` (a raw
Zenoh session in a child process), ``netcomps`` (the components those deploy) and
``foxclient`` (a Foxglove WebSocket client). The toolkit imports ESAIR and libraries,
never a bench or the tests (tests/test_bench_list.py)."""

from __future__ import annotations

import os
import socket
import time
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

#: The bench folder and the checkout it belongs to.
BENCH = Path(__file__).resolve().parents[1]
ROOT = BENCH.parent
T = TypeVar("T")

#: Debian's chromium (the install step installs it with apt; Playwright downloads none),
#: headless, with nothing of its own running in the background
CHROMIUM = "/usr/bin/chromium"
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--no-first-run"]


def free_port() -> int:
    """A TCP port nobody listens on now (the kernel's pick)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def free_endpoint() -> str:
    """A Zenoh endpoint on this computer at a free port: ``tcp/127.0.0.1:PORT``."""
    return f"tcp/127.0.0.1:{free_port()}"


def ratio(value: float, baseline: float, digits: int = 2) -> str:
    """``value`` as a multiple of ``baseline`` (``1.83x``); ``-`` when the baseline is 0."""
    return f"{value / baseline:.{digits}f}x" if baseline else "-"


def wait_for(fn: Callable[[], T], timeout: float = 10.0,
             what: str | Callable[[], str] = "condition") -> T:
    """Poll ``fn()`` until it returns a truthy value, returned; AssertionError after
    ``timeout`` seconds, saying ``what`` (a callable: what it says then). Polls every
    5 ms at first, then less often (up to every 50 ms): a short wait ends at once, a
    long one does not keep a core busy."""
    deadline = time.monotonic() + timeout
    pause = 0.005
    while True:
        v = fn()
        if v:
            return v
        if time.monotonic() > deadline:
            said = what() if callable(what) else what
            raise AssertionError(f"timed out waiting for {said}; last value {v!r}")
        time.sleep(pause)
        pause = min(pause * 1.5, 0.05)


def processes() -> list[tuple[int, int, bytes]]:
    """(pid, parent pid, command line) of every process readable in /proc now."""
    out = []
    for d in os.listdir("/proc"):
        if not d.isdigit():
            continue
        try:
            with open(f"/proc/{d}/stat") as f:
                ppid = int(f.read().rsplit(")", 1)[1].split()[1])
            with open(f"/proc/{d}/cmdline", "rb") as f:
                cmd = f.read()
        except (OSError, IndexError, ValueError):
            continue
        out.append((int(d), ppid, cmd))
    return out
