"""Checked deployments kept between starts: one JSON file per deployment and command
line, valid while every file it was made from hashes the same.

Where: ``$ESAIR_STD_CACHE`` (a folder; empty: no cache), else ``std`` in ESAIR's
cache folder (esair_min/cachedir.py: ``$ESAIR_CACHE``, ``$XDG_CACHE_HOME/esair``,
``~/.cache/esair``) — never inside the installed package. The key is the deployment's
absolute path, the command line's overrides, the
package's version and this layout's, and ``sys.path`` (where classes are found); the
entry holds the SHA-256 of each input (the deployment, each class's module, the board
files). An entry that cannot be read, is
damaged, of another layout, or whose inputs changed is simply not used (the checking
child makes a new one); a folder that cannot be written is no error (no cache then).
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
from pathlib import Path
from typing import Any, Iterable, Mapping

from esair_min.cachedir import cache_root

from .plain import FORMAT, PlainDeployment

VERSION = "esair-std-lean/1"


def folder() -> Path | None:
    env = os.environ.get("ESAIR_STD_CACHE")
    if env is not None:
        return Path(env) if env else None
    root = cache_root()
    return None if root is None else root / "std"


def key(path: str | Path, overrides: Mapping[str, object]) -> str:
    from esair_min import __version__
    what = [VERSION, FORMAT, __version__, list(sys.version_info[:2]),
            str(Path(path).resolve()), overrides, sys.path]
    return hashlib.sha256(json.dumps(what, sort_keys=True, default=str).encode()).hexdigest()[:32]


def hashes(files: Iterable[str]) -> dict[str, str]:
    """Each file's SHA-256 (a file that cannot be read: "")."""
    return {f: _sha(f) for f in files}


def _sha(path: str) -> str:
    try:
        with open(path, "rb") as f:
            return hashlib.sha256(f.read()).hexdigest()
    except OSError:
        return ""


def read(k: str) -> PlainDeployment | None:
    """The cached plain deployment of key ``k``, if its inputs are all unchanged."""
    where = folder()
    if where is None:
        return None
    try:
        with open(where / f"{k}.json", encoding="utf-8") as f:
            entry: Any = json.load(f)
        inputs = entry["inputs"]
        if not isinstance(inputs, dict) or not all(
                isinstance(h, str) and h and _sha(p) == h for p, h in inputs.items()):
            return None
        return PlainDeployment.from_json(entry["deployment"])
    except (OSError, ValueError, KeyError, TypeError):
        return None


def write(k: str, deployment: object, inputs: object) -> None:
    """Keep a plain deployment under ``k`` (quietly nothing where that cannot be done)."""
    where = folder()
    if where is None or not isinstance(inputs, dict) or not all(inputs.values()):
        return
    tmp = where / f".{k}.{os.getpid()}.tmp"
    try:
        where.mkdir(parents=True, exist_ok=True)
        with open(tmp, "w", encoding="utf-8") as f:
            # dumps: C's encoder (json.dump to a file takes Python's)
            f.write(json.dumps({"deployment": deployment, "inputs": inputs}))
        os.replace(tmp, where / f"{k}.json")
    except OSError:
        try:
            tmp.unlink()
        except OSError:
            pass
