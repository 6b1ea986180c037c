"""Signal handlers that keep an inherited ignore: a command started as a shell's
background job (``esair std run lab &``) has SIGINT ignored, so a Ctrl-C typed for the
foreground job is not meant for it. Installing a handler over that ignore would make
the background job stop too; :func:`install` and :func:`ignored` leave it in place."""

from __future__ import annotations

import signal
from typing import Any


def ignored(sig: int) -> bool:
    """Whether ``sig`` is ignored in this process (inherited, or set earlier)."""
    return signal.getsignal(sig) is signal.SIG_IGN


def install(sig: int, handler: Any) -> Any:
    """``signal.signal(sig, handler)`` unless ``sig`` is ignored; the previous handler
    (SIG_IGN, left as it is, when it was ignored)."""
    if ignored(sig):
        return signal.SIG_IGN
    return signal.signal(sig, handler)
