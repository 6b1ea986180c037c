"""Robots talking to robots: a behavior of robot ``a`` puts to (or gets from) behavior
``turn`` of robot ``b`` by naming it ``b/turn``, once the two control centers are joined
(``esair std run FILE --join tcp/B_HOST:PORT`` on one of them: their Zenoh sessions
connect; every key starts with the robot's name, so nothing collides).

The request goes to b's control center (``esair/b/ctl/put`` / ``ctl/get``) with the
sender named ``a/<behavior>``; b's BS delivers it like any put, with the same retry,
timeout and failure rules. Only put and get cross: resources stay with their robot.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

from ..errors import StdError
from ..transport import keys, wire
from ..transport.codec import JSON, JSONObject

if TYPE_CHECKING:  # pragma: no cover
    from ..runtime_view import RuntimeView

ROBOT_NAME = re.compile(r"^[a-z][a-z0-9_]{0,31}$")


def split(target: str) -> tuple[str, str] | None:
    """("b", "turn") for "b/turn"; None for a local name."""
    robot, sep, name = target.partition("/")
    return (robot, name) if sep else None


def put(rt: RuntimeView, sender: str, target: str, data: JSON, timeout: float) -> tuple[bool, str]:
    robot, name = split(target) or ("", "")   # a local name: not of the form robot/behavior
    if not ROBOT_NAME.match(robot) or not name:
        return False, f"{target!r} is not of the form robot/behavior"
    if robot == rt.robot:
        return rt.bs.put(sender, name, data, timeout)
    r = _ask(rt, robot, "put", {"from": f"{rt.robot}/{sender}", "to": name, "data": data,
                                "timeout": timeout}, timeout)
    if isinstance(r, str):
        return False, r
    return bool(r.get("delivered")), str(r.get("reason", ""))


def get(rt: RuntimeView, requester: str, target: str, timeout: float) -> tuple[bool, JSON]:
    robot, name = split(target) or ("", "")   # a local name: not of the form robot/behavior
    if not ROBOT_NAME.match(robot) or not name:
        return False, f"{target!r} is not of the form robot/behavior"
    if robot == rt.robot:
        return rt.bs.get(requester, name, timeout)
    r = _ask(rt, robot, "get", {"from": f"{rt.robot}/{requester}", "to": name,
                                "timeout": timeout}, timeout)
    if isinstance(r, str):
        return False, r
    return (True, r.get("data")) if r.get("ok") else (False, str(r.get("reason", "")))


def _ask(rt: RuntimeView, robot: str, verb: str, body: JSONObject,
         timeout: float) -> JSONObject | str:
    server = getattr(rt, "server", None)
    if server is None or server.bus is None:
        return f"robot {robot!r} is out of reach: this runtime has no control endpoint"
    r = server.bus.request(keys.ctl(robot, verb), body, timeout + 2.0)
    if r is None:
        return f"robot {robot!r} did not answer (not joined, or unreachable)"
    try:
        ok = wire.result(r)
    except StdError as exc:
        return f"robot {robot!r}: {exc}"
    return ok if isinstance(ok, dict) else f"robot {robot!r}: bad answer"
