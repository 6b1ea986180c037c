"""The firmware's build id: the first 8 hex digits of a SHA-256 of the central board's
generated sources, rendered with a placeholder id (the id cannot hash itself).

The board answers it in ``v`` and ``!READY`` (``build=``, docs/protocol.md): a host that
just generated the same sources (``esair run``) knows the chip already runs them. The
Python core is given the same id, so its replies equal the firmware's byte for byte.

Rendering costs an emulator's start a good part of its time (Jinja2's import and the
central board's templates), so each id is also kept on disk (:func:`cache_dir`), under
a key that hashes the robot's model and every file the rendering may read (the
generator, the model's and the components' code, the templates): any change to one of
them is another key, hence a new rendering.
"""

from __future__ import annotations

import hashlib
import os
import re
import tempfile
from pathlib import Path

from esair_min.cachedir import cache_root
from esair_min.model.robot import Robot

_CACHE: dict[int, tuple[Robot, str]] = {}    # id(robot) -> (robot kept alive, its id)
_ID = re.compile(r"[0-9a-f]{8}")
_sources_digest: bytes | None = None         # of this process's code and templates


def central_build_id(robot: Robot) -> str:
    """The build id of ``robot``'s central board firmware (8 lower-case hex digits)."""
    hit = _CACHE.get(id(robot))
    if hit is not None and hit[0] is robot:
        return hit[1]
    key = _key(robot)
    value = _read(key)
    if value is None:
        value = _render_id(robot)
        _write(key, value)
    if len(_CACHE) >= 16:
        _CACHE.clear()
    _CACHE[id(robot)] = (robot, value)
    return value


def _render_id(robot: Robot) -> str:
    from .context import BUILD_PLACEHOLDER, central_context
    from .render import render_board
    files = render_board("central", central_context(robot, BUILD_PLACEHOLDER))
    h = hashlib.sha256()
    for rel in sorted(files):
        h.update(rel.encode() + b"\0" + files[rel].encode() + b"\0")
    return h.hexdigest()[:8]


def cache_dir() -> Path | None:
    """Where the ids are kept: ``build-id`` in ESAIR's cache folder
    (esair_min/cachedir.py; None: none kept). Nothing breaks when it cannot be
    written: the id is rendered each time."""
    root = cache_root()
    return None if root is None else root / "build-id"


def _key(robot: Robot) -> str:
    h = hashlib.sha256(_sources())
    h.update(repr((robot.name, robot.source, robot.files)).encode())
    for board in robot.boards:
        h.update(b"\0" + board.model_dump_json().encode())
    return h.hexdigest()[:40]


def _sources() -> bytes:
    """A digest of every file of the esair_min package, the generator and the firmware
    templates (what the rendering may read), read once a process."""
    global _sources_digest
    if _sources_digest is None:
        import esair_min
        from esair_min.resources import templates_dir
        h = hashlib.sha256(esair_min.__version__.encode())
        for top in (Path(esair_min.__file__).parent, Path(__file__).resolve().parent,
                    templates_dir()):
            for path in sorted(_files(top)):
                h.update(b"\0" + str(path.relative_to(top)).encode() + b"\0"
                         + path.read_bytes())
        _sources_digest = h.digest()
    return _sources_digest


def _files(top: Path) -> list[Path]:
    out = []
    for folder, dirs, names in os.walk(top):        # the checkout's codegen link not followed
        dirs[:] = [d for d in dirs if d != "__pycache__"]
        out += [Path(folder) / n for n in names if not n.endswith((".pyc", ".pyo"))]
    return out


def _read(key: str) -> str | None:
    folder = cache_dir()
    if folder is None:
        return None
    try:
        value = (folder / key).read_text()
    except (OSError, UnicodeDecodeError):
        return None
    return value if _ID.fullmatch(value) else None


def _write(key: str, value: str) -> None:
    folder = cache_dir()
    if folder is None:
        return
    try:
        folder.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=".tmp-")
        with os.fdopen(fd, "w") as f:
            f.write(value)
        os.replace(tmp, folder / key)       # whole or absent, for a reader beside it
    except OSError:
        pass
