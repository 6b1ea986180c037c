"""The control client used by ``esair std ls/add/...``: one Zenoh session connected to
the runtime's control endpoint, one request per command."""

from __future__ import annotations

import json
import os
from typing import Any

from ..errors import TransportError
from ..transport import keys, wire
from ..transport.bus import Bus
from ..transport.codec import JSONObject
from ..transport.session import check_endpoint

DEFAULT_ENDPOINT = "tcp/127.0.0.1:7447"


def default_endpoint() -> str:
    return os.environ.get("ESAIR_STD_ENDPOINT", DEFAULT_ENDPOINT)


class Client:
    def __init__(self, endpoint: str | None = None, robot: str | None = None,
                 timeout: float = 5.0):
        self.endpoint = check_endpoint(endpoint or default_endpoint())
        self.timeout = timeout
        # ESAIR_STD_SESSION: extra Zenoh options as JSON, e.g. a login when the robot's
        # security section lists users (docs/std-network.md)
        extra = os.environ.get("ESAIR_STD_SESSION") or "{}"
        try:
            options = json.loads(extra)
        except ValueError:
            raise TransportError("ESAIR_STD_SESSION is not a JSON object") from None
        # the client dials the runtime only, and nobody dials it: no listener, no peers
        # taken from gossip (it asks the runtime, which reads the agents for it)
        alone: JSONObject = {"listen/endpoints": [], "scouting/gossip/autoconnect": {"peer": []}}
        self.bus = Bus(connect=[self.endpoint], options={**alone, **options},
                       runtime=self.endpoint)
        try:
            self.robot = robot or self._find_robot()
        except BaseException:
            self.bus.close()
            raise

    def _find_robot(self) -> str:
        robot = self.bus.runtime_robot()
        if robot is None:
            raise TransportError(f"no ESAIR STD runtime answers on {self.endpoint} "
                                 "(is `esair std run` running?)")
        return robot

    def call(self, verb: str, body: JSONObject | None = None,
             timeout: float | None = None) -> Any:    # the ok value, read as the verb says
        r = self.bus.request(keys.ctl(self.robot, verb), body or {}, timeout or self.timeout)
        if r is None:
            raise TransportError(f"the runtime of robot {self.robot!r} on {self.endpoint} "
                                 f"did not answer {verb!r}")
        return wire.result(r)     # an error raised as the class the runtime raised

    def close(self) -> None:
        self.bus.close()

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
