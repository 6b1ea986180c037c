"""What a Foxglove client may ask of the robot through the live server (foxserver.py,
docs/foxglove.md): a command (a joint angle, a motion: any actuator's command, as
``esair std send``), the latched STOP and its release. The same three as services
(a call, an answer) and as client-publish topics (``/esair/command``, ``/esair/stop``,
``/esair/release``: JSON messages, the answer as a status message), both through the
RS like every other sender: a command as the principal ``operator``, so only where the
deployment's ``allow`` grants ``operator: command``."""

from __future__ import annotations

import json
from ..hmi.bridge import Bridge, BridgeError
from ..transport.codec import JSON

PRINCIPAL, COMMANDER = "foxglove", "operator"

REQUESTS = {
    "command": {"type": "object", "title": "esair.CommandRequest", "required": ["resource", "command"],
                "properties": {"resource": {"type": "string", "description": "the actuator, e.g. "
                                            "papaman.servo.l_knee or papaman.motion"},
                               "command": {"description": "the command, as esair std send: "
                                           "{\"angle\": 100} to a servo, a motion's name"}}},
    "stop": {"type": "object", "title": "esair.StopRequest",
             "properties": {"reason": {"type": "string"}}},
    "release": {"type": "object", "title": "esair.ReleaseRequest", "properties": {}},
}
RESPONSE = {"type": "object", "title": "esair.ServiceResponse",
            "properties": {"ok": {"description": "the runtime's answer"}}}
TOPICS = {f"/esair/{name}": name for name in REQUESTS}     # client publish -> the request


def parse(payload: bytes) -> dict[str, JSON]:
    """A request's JSON object (empty: ``{}``), or BridgeError."""
    try:
        body = json.loads(payload) if payload else {}
    except ValueError as exc:
        raise BridgeError(f"not JSON: {exc}") from None
    if not isinstance(body, dict):
        raise BridgeError("the request must be a JSON object")
    return body


def run(bridge: Bridge, name: str, body: dict[str, JSON]) -> JSON:
    """Request ``name`` (a key of REQUESTS) with ``body`` through the RS: the runtime's
    answer, or BridgeError with its words (a refusal among them). Blocks: not on the
    server's loop."""
    if name == "command":
        res = body.get("resource")
        if not isinstance(res, str) or "command" not in body:
            raise BridgeError("a command needs 'resource' and 'command'")
        return bridge.call("command", {"who": COMMANDER, "resource": res,
                                       "command": body["command"], "timeout": 2.0}, 5.0)
    if name == "stop":
        return bridge.call("stop", {"who": PRINCIPAL, "reason": str(body.get("reason") or "")},
                           10.0)
    return bridge.call("release", {"who": COMMANDER}, 10.0)
