"""The firmware's build id: the first 8 hex digits of a SHA-256 of the central board's
generated sources, rendered with a placeholder id (the id cannot hash itself).

The board answers it in ``v`` and ``!READY`` (``build=``, docs/protocol.md): a host that
just generated the same sources (``esair run``) knows the chip already runs them. The
Python core is given the same id, so its replies equal the firmware's byte for byte.
"""

from __future__ import annotations

import hashlib

from esair_min.model.robot import Robot

from .context import BUILD_PLACEHOLDER, central_context
from .render import render_board
_CACHE: dict[int, tuple[Robot, str]] = {}    # id(robot) -> (robot kept alive, its id)


def central_build_id(robot: Robot) -> str:
    """The build id of ``robot``'s central board firmware (8 lower-case hex digits)."""
    hit = _CACHE.get(id(robot))
    if hit is not None and hit[0] is robot:
        return hit[1]
    files = render_board("central", central_context(robot, BUILD_PLACEHOLDER))
    h = hashlib.sha256()
    for rel in sorted(files):
        h.update(rel.encode() + b"\0" + files[rel].encode() + b"\0")
    value = h.hexdigest()[:8]
    if len(_CACHE) >= 16:
        _CACHE.clear()
    _CACHE[id(robot)] = (robot, value)
    return value
