"""A Foxglove WebSocket protocol client (subprotocol ``foxglove.websocket.v1``) on the
plain ``websockets`` package, for the live server's tests and bench/foxglove_figures.py:
subscribes to every channel advertised, decodes each message against its schema
(tests/support/foxcheck.py, in the tests), calls services, publishes on client channels
and keeps the status messages."""

from __future__ import annotations

import base64
import json
import struct
import time
from dataclasses import dataclass
from typing import Any, Callable

from websockets.sync.client import ClientConnection, connect

SUBPROTOCOL = "foxglove.websocket.v1"


@dataclass
class Chan:
    topic: str
    name: str
    encoding: str
    data: bytes


class FoxClient:
    def __init__(self, url: str, origin: str | None = None):
        # max_queue=None: frames are read off the socket as they come, also between
        # pumps, so close() gets the server's close frame at once (with the default
        # 16-frame queue full, reading stops and close() waits out its 10 s)
        self._cm = connect(url, subprotocols=[SUBPROTOCOL],   # type: ignore[list-item]
                           origin=origin, max_size=None,  # type: ignore[arg-type]
                           max_queue=None)
        self.ws: ClientConnection = self._cm.__enter__()
        self.channels: dict[int, Chan] = {}
        self.services: dict[str, int] = {}
        self.subs: dict[int, int] = {}          # subscription id -> channel id
        self.info: dict = {}
        self.got: list[tuple[str, int, bytes, float]] = []   # topic, log ns, data, rx
        self.answers: dict[int, tuple[bool, Any]] = {}
        self.statuses: list[tuple[int, str]] = []          # level, message
        self._calls = 0
        self._pubs: dict[str, int] = {}                   # topic -> its client channel id

    def close(self) -> None:
        self._cm.__exit__(None, None, None)

    def pump(self, seconds: float = 0.2, until: Callable[[], bool] | None = None) -> None:
        """Read what comes for ``seconds``, or until ``until()`` holds after a frame;
        subscribe to each new channel."""
        end = time.monotonic() + seconds
        while True:
            left = end - time.monotonic()
            if left <= 0:
                return
            try:
                frame = self.ws.recv(timeout=left)
            except TimeoutError:
                return
            self._frame(frame)
            if until is not None and until():
                return

    def wait_ready(self, timeout: float = 15.0) -> None:
        """Read until the server has said who it is and advertised its channels and
        services (what it sends a new client first)."""
        end = time.monotonic() + timeout
        while not (self.info and self.channels and self.services):
            if time.monotonic() >= end:
                raise TimeoutError(f"the server sent no serverInfo, channels and services "
                                   f"within {timeout} s")
            self.pump(0.05)

    def _frame(self, frame: str | bytes) -> None:
        if isinstance(frame, str):
            m = json.loads(frame)
            op = m["op"]
            if op == "serverInfo":
                self.info = m
            elif op == "advertise":
                new = []
                for c in m["channels"]:
                    data = (base64.b64decode(c["schema"]) if c["schemaEncoding"] == "protobuf"
                            else c["schema"].encode())
                    self.channels[c["id"]] = Chan(c["topic"], c["schemaName"],
                                                  c["schemaEncoding"], data)
                    new.append({"id": 1000 + c["id"], "channelId": c["id"]})
                    self.subs[1000 + c["id"]] = c["id"]
                self.ws.send(json.dumps({"op": "subscribe", "subscriptions": new}))
            elif op == "advertiseServices":
                self.services.update({s["name"]: s["id"] for s in m["services"]})
            elif op == "serviceCallFailure":
                self.answers[m["callId"]] = (False, m["message"])
            elif op == "status":
                self.statuses.append((m["level"], m["message"]))
            return
        if frame[0] == 1:
            sub, ns = struct.unpack_from("<IQ", frame, 1)
            self.got.append((self.channels[self.subs[sub]].topic, ns, frame[13:], time.time()))
        elif frame[0] == 3:
            _sid, call, n = struct.unpack_from("<III", frame, 1)
            self.answers[call] = (True, json.loads(frame[13 + n:])["ok"])

    def call(self, service: str, body: dict, timeout: float = 15.0) -> tuple[bool, Any]:
        self._calls += 1
        call = self._calls
        enc = b"json"
        self.ws.send(struct.pack("<BIII", 2, self.services[service], call, len(enc)) + enc
                     + json.dumps(body).encode())
        self.pump(timeout, until=lambda: call in self.answers)
        return self.answers.pop(call)

    def advertise(self, topic: str, encoding: str = "json") -> int:
        """A client channel (client publish) on ``topic``: its id."""
        cid = self._pubs[topic] = len(self._pubs) + 1
        self.ws.send(json.dumps({"op": "advertise", "channels": [
            {"id": cid, "topic": topic, "encoding": encoding, "schemaName": topic}]}))
        return cid

    def publish(self, topic: str, body: Any, timeout: float = 15.0) -> tuple[int, str]:
        """``body`` (JSON) on the client channel of ``topic`` (advertised first): the
        status the server answers with (level, message)."""
        cid = self._pubs.get(topic) or self.advertise(topic)
        return self.send_expecting_status(struct.pack("<BI", 1, cid) + json.dumps(body).encode(),
                                          timeout)

    def send_expecting_status(self, frame: str | bytes, timeout: float = 15.0) -> tuple[int, str]:
        """Send ``frame``; the next status message the server sends."""
        seen = len(self.statuses)
        self.ws.send(frame)
        self.pump(timeout, until=lambda: len(self.statuses) > seen)
        return self.statuses[seen]
