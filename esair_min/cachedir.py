"""Where ESAIR keeps what it can always make again (firmware build ids, checked
deployments): ``$ESAIR_CACHE``, else ``$XDG_CACHE_HOME/esair``, else ``~/.cache/esair``;
``ESAIR_CACHE`` set empty keeps nothing. Never inside the installed package."""

from __future__ import annotations

import os
from pathlib import Path


def cache_root() -> Path | None:
    env = os.environ.get("ESAIR_CACHE")
    if env is not None:
        return Path(env) if env else None
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "esair"
