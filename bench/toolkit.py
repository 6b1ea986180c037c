"""What the benches repeat: the checkout's folders, a free local port or Zenoh endpoint
(never 7447), and a ratio printed the one way every bench prints it."""

from __future__ import annotations

import socket
from pathlib import Path

#: The bench folder and the checkout it belongs to.
BENCH = Path(__file__).resolve().parent
ROOT = BENCH.parent


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
