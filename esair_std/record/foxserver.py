"""``esair std foxglove``: a running robot, live, in Foxglove / Lichtblick (docs/foxglove.md).

A component like the HMI: a :class:`~esair_std.hmi.bridge.Bridge` registers with the RS
as the principal ``foxglove`` (read, as the deployment's ``allow`` permits) and the
channels are the recording's (foxmsgs.py). It speaks the Foxglove WebSocket protocol
(subprotocol ``foxglove.websocket.v1``) with the ``websockets`` package rather than the
SDK's server, because that server cannot refuse a foreign ``Origin``: any web page the
user opens could otherwise read the robot and call its services from the browser. As
the HMI, a handshake whose ``Origin`` is not this server's own (or one given with
``--allow-origin``) gets 403.

Services (JSON): ``command`` {resource, command} sends through the RS as the principal
``operator`` (so only where the resource's ``allow`` grants ``operator: command``, as
``esair std send``), ``stop`` {reason} and ``release`` {} the latched STOP, as
``foxglove``. The bridge's threads only queue (bounded, drops counted); the loop converts
and writes each subscriber's frames (a client whose socket holds more than
CLIENT_BUFFER bytes loses frames, counted)."""

from __future__ import annotations

import asyncio
import base64
import json
import logging
import ssl as _ssl
import struct
import threading
import time
from http import HTTPStatus
from typing import Callable

from websockets.asyncio.server import ServerConnection, serve
from websockets.exceptions import ConnectionClosed
from websockets.http11 import Request, Response
from websockets.protocol import State

from ..counters import Counters
from ..hmi.bridge import Bridge, BridgeError
from ..transport import keys, records
from ..transport.codec import JSON
from .foxmsgs import Converter, Out, Schema
from .mcapio import LATCH, LATCH_TOPIC

log = logging.getLogger("esair_std.foxglove")
SUBPROTOCOL = "foxglove.websocket.v1"
PENDING_MAX = 20_000          # emitted, not yet converted (counted as dropped past it)
CLIENT_BUFFER = 4 * 1024 * 1024
PRINCIPAL, COMMANDER = "foxglove", "operator"
MESSAGE_DATA, SERVICE_REQUEST, SERVICE_RESPONSE = 1, 2, 3

REQUESTS = {
    "command": {"type": "object", "title": "esair.CommandRequest", "required": ["resource", "command"],
                "properties": {"resource": {"type": "string", "description": "the actuator"},
                               "command": {"description": "the command, as esair std send"}}},
    "stop": {"type": "object", "title": "esair.StopRequest",
             "properties": {"reason": {"type": "string"}}},
    "release": {"type": "object", "title": "esair.ReleaseRequest", "properties": {}},
}
RESPONSE = {"type": "object", "title": "esair.ServiceResponse",
            "properties": {"ok": {"description": "the runtime's answer"}}}


class _Client:
    def __init__(self, ws: ServerConnection):
        self.ws = ws
        self.subs: dict[int, int] = {}          # channel id -> subscription id
        self.c = Counters(sent=0, dropped=0)
        self.out: list[str | bytes] = []        # frames of this flush, written at its end


class FoxServer:
    def __init__(self, endpoint: str, host: str, port: int, tls: _ssl.SSLContext | None = None,
                 origins: list[str] | None = None):
        self.endpoint, self.host, self.port, self.tls = endpoint, host, port, tls
        self.origins = set(origins or [])
        self.conv = Converter()
        self.bridge: Bridge | None = None
        self.clients: set[_Client] = set()
        self.channels: dict[str, tuple[int, Schema]] = {}
        self.last: dict[int, tuple[int, bytes]] = {}    # channel id -> its last message
        self.c = Counters(messages=0, dropped=0, origin_refused=0, calls=0, call_errors=0)
        self.url = ""
        self._loop: asyncio.AbstractEventLoop | None = None
        self._pending: list[dict] = []
        self._lock = threading.Lock()
        self._woken = False

    # ---- any thread: queue and wake the loop once
    def emit(self, msg: dict) -> None:
        loop = self._loop
        if loop is None:
            return
        with self._lock:
            if len(self._pending) >= PENDING_MAX:
                self.c.add("dropped")
                return
            self._pending.append(msg)
            if self._woken:
                return
            self._woken = True
        loop.call_soon_threadsafe(self._flush)

    def _on_commands(self, key: str, obj: JSON) -> None:
        got, _bad = records.unpack(key, obj)
        for res, rec in got:
            self.emit({"t": "c", "r": res, "m": rec})

    # ---- the loop
    def _flush(self) -> None:
        with self._lock:
            got, self._pending = self._pending, []
            self._woken = False
        for m in got:
            for out in self._convert(m):
                self._publish(out)
        for client in list(self.clients):
            self._write(client)

    def _convert(self, m: dict) -> list[Out]:
        kind = m.get("t")
        try:
            if kind == "c":
                rec = m["m"]
                return self.conv.command(m["r"], int(rec["seq"]), float(rec["t"]), dict(rec["v"]))
            if kind == "latch" and isinstance(m.get("v"), dict):
                v = m["v"]
                t = float(v["t"]) if isinstance(v.get("t"), (int, float)) else time.time()
                body = dict({k: x for k, x in v.items() if k != "t"}, seq=0, t=t)
                return [Out(LATCH_TOPIC, LATCH, json.dumps(body).encode(), t)]
            return self.conv.message(m)
        except (KeyError, TypeError, ValueError):
            self.c.add("dropped")
            return []

    def _publish(self, out: Out) -> None:
        ch = self.channels.get(out.topic)
        if ch is None:
            ch = self.channels[out.topic] = (len(self.channels) + 1, out.schema)
            adv = json.dumps({"op": "advertise", "channels": [self._channel(out.topic, *ch)]})
            for client in list(self.clients):
                self._send(client, adv)
        cid = ch[0]
        ns = int(out.t * 1e9)
        self.last[cid] = (ns, out.data)
        self.c.add("messages")
        for client in list(self.clients):
            sub = client.subs.get(cid)
            if sub is not None:
                self._data(client, sub, ns, out.data)

    def _data(self, client: _Client, sub: int, ns: int, data: bytes) -> None:
        transport = client.ws.transport
        if transport is not None and transport.get_write_buffer_size() > CLIENT_BUFFER:
            client.c.add("dropped")
            self.c.add("dropped")
            return
        client.c.add("sent")
        client.out.append(struct.pack("<BIQ", MESSAGE_DATA, sub, ns) + data)

    @staticmethod
    def _send(client: _Client, frame: str | bytes) -> None:
        """One frame now, after those waiting (in order, never waits)."""
        client.out.append(frame)
        FoxServer._write(client)

    @staticmethod
    def _write(client: _Client) -> None:
        """The frames waiting, in one write to the socket (one frame each, as the
        protocol has it: one system call per message cost more than the rest of the
        server's loop)."""
        frames, client.out = client.out, []
        ws = client.ws
        if not frames or ws.state is not State.OPEN or ws.transport is None:
            return
        for f in frames:
            if isinstance(f, str):
                ws.protocol.send_text(f.encode())
            else:
                ws.protocol.send_binary(f)
        ws.transport.write(b"".join(ws.protocol.data_to_send()))

    @staticmethod
    def _channel(topic: str, cid: int, schema: Schema) -> dict:
        text = (base64.b64encode(schema.data).decode() if schema.encoding == "protobuf"
                else schema.data.decode())
        return {"id": cid, "topic": topic, "encoding": schema.message_encoding,
                "schemaName": schema.name, "schema": text, "schemaEncoding": schema.encoding}

    # ---- the handshake: the HMI's Origin rule
    def _http(self, connection: ServerConnection, request: Request) -> Response | None:
        origin = request.headers.get("Origin")
        if origin is None or origin in self.origins:
            return None
        scheme = "https" if self.tls else "http"
        if origin == f"{scheme}://{request.headers.get('Host', '')}":
            return None
        self.c.add("origin_refused")
        log.warning("WebSocket from origin %s refused (add it with --allow-origin)", origin)
        return connection.respond(HTTPStatus.FORBIDDEN, "origin refused\n")

    # ---- one client
    async def _client(self, ws: ServerConnection) -> None:
        client = _Client(ws)
        await ws.send(json.dumps({
            "op": "serverInfo", "name": f"esair {self.bridge.robot if self.bridge else ''}",
            "capabilities": ["services"], "supportedEncodings": ["json"], "metadata": {},
            "sessionId": str(int(time.time()))}))
        await ws.send(json.dumps({"op": "advertise", "channels": [
            self._channel(t, *ch) for t, ch in self.channels.items()]}))
        await ws.send(json.dumps({"op": "advertiseServices", "services": [
            {"id": i + 1, "name": name, "type": f"esair.{name}",
             "request": {"encoding": "json", "schemaName": req["title"],
                         "schemaEncoding": "jsonschema", "schema": json.dumps(req)},
             "response": {"encoding": "json", "schemaName": RESPONSE["title"],
                          "schemaEncoding": "jsonschema", "schema": json.dumps(RESPONSE)}}
            for i, (name, req) in enumerate(REQUESTS.items())]}))
        self.clients.add(client)
        try:
            async for frame in ws:
                if isinstance(frame, bytes):
                    await self._binary(client, frame)
                else:
                    self._text(client, frame)
        except ConnectionClosed:
            pass
        finally:
            self.clients.discard(client)

    def _text(self, client: _Client, frame: str) -> None:
        try:
            m = json.loads(frame)
            op = m.get("op")
            if op == "subscribe":
                for s in m["subscriptions"]:
                    cid, sub = int(s["channelId"]), int(s["id"])
                    client.subs[cid] = sub
                    if cid in self.last:             # what it shows now: its last message
                        self._data(client, sub, *self.last[cid])
            elif op == "unsubscribe":
                gone = {int(i) for i in m["subscriptionIds"]}
                client.subs = {c: s for c, s in client.subs.items() if s not in gone}
        except (ValueError, KeyError, TypeError, AttributeError) as exc:
            self._send(client, json.dumps({"op": "status", "level": 2,
                                           "message": f"bad request: {exc}"}))

    async def _binary(self, client: _Client, frame: bytes) -> None:
        if len(frame) < 13 or frame[0] != SERVICE_REQUEST:
            return
        sid, call, n = struct.unpack_from("<III", frame, 1)
        encoding, payload = frame[13:13 + n], frame[13 + n:]
        names = list(REQUESTS)
        self.c.add("calls")
        try:
            if not 0 < sid <= len(names):
                raise BridgeError(f"no service {sid}")
            body = json.loads(payload) if payload else {}
            if not isinstance(body, dict):
                raise BridgeError("the request must be a JSON object")
            assert self._loop is not None
            ok = await self._loop.run_in_executor(None, self._call, names[sid - 1], body)
        except (BridgeError, ValueError) as exc:
            self.c.add("call_errors")
            self._send(client, json.dumps({"op": "serviceCallFailure", "serviceId": sid,
                                           "callId": call, "message": str(exc)}))
            return
        out = json.dumps({"ok": ok}).encode()
        self._send(client, struct.pack("<BIII", SERVICE_RESPONSE, sid, call, len(encoding))
                   + encoding + out)

    def _call(self, name: str, body: dict) -> JSON:
        bridge = self.bridge
        assert bridge is not None
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

    # ---- life cycle
    async def serve(self, ready: Callable[[str], None], stop: asyncio.Event) -> None:
        self._loop = asyncio.get_running_loop()
        self.bridge = Bridge(self.endpoint, self.emit, who=PRINCIPAL)
        bridge = self.bridge
        bridge.showing = lambda: bool(self.clients)     # behaviors' states: while one looks
        await self._loop.run_in_executor(None, bridge.start)
        assert bridge.bus is not None
        bridge.bus.subscribe(keys.commands_all(bridge.robot), self._on_commands, with_key=True)
        self.emit({"t": "latch", "v": bridge.latch})
        try:
            async with serve(self._client, self.host, self.port, process_request=self._http,
                             ssl=self.tls, subprotocols=[SUBPROTOCOL],   # type: ignore[list-item]
                             server_header=None, compression=None, max_size=1 << 20) as server:
                port = server.sockets[0].getsockname()[1]
                host = f"[{self.host}]" if ":" in self.host else self.host
                self.url = f"{'wss' if self.tls else 'ws'}://{host}:{port}"
                ready(self.url)
                await stop.wait()
        finally:
            bridge.close()

