"""``esair std foxglove``: a running robot, live, in Foxglove / Lichtblick (docs/foxglove.md).

A component like the HMI: a :class:`~esair_std.hmi.bridge.Bridge` registers with the RS
as the principal ``foxglove`` (read, as the deployment's ``allow`` permits) and the
channels are the recording's (foxmsgs.py). It speaks the Foxglove WebSocket protocol
(subprotocol ``foxglove.websocket.v1``) with the ``websockets`` package rather than the
SDK's server, because that server cannot refuse a foreign ``Origin``: any web page the
user opens could otherwise read the robot and call its services from the browser. As
the HMI, a handshake whose ``Origin`` is not this server's own (or one given with
``--allow-origin``) gets 403.

Commands (foxcommands.py): services ``command`` {resource, command}, ``stop`` {reason}
and ``release`` {}, and the same as client-publish topics ``/esair/command`` ...; through
the RS, a command as the principal ``operator`` (only where the resource's ``allow``
grants ``operator: command``). A frame the protocol does not know gets an error status;
the client stays connected and loses nothing. The bridge's threads only queue (bounded,
drops counted); the loop converts and writes each subscriber's frames (a client whose
socket holds more than CLIENT_BUFFER bytes loses frames, counted)."""

from __future__ import annotations

import asyncio
import base64
import json
import logging
import ssl as _ssl
import struct
import time
from http import HTTPStatus
from typing import Callable

from websockets.asyncio.server import ServerConnection, serve
from websockets.exceptions import ConnectionClosed
from websockets.http11 import Request, Response
from websockets.protocol import State

from ..counters import Counters
from ..hmi.bridge import Bridge, BridgeError
from ..hmi.handover import Handover
from ..transport import records
from ..transport.codec import JSON
from . import foxcommands as cmds
from .foxmsgs import LATCH, LATCH_TOPIC, Converter, Out, Schema

log = logging.getLogger("esair_std.foxglove")
SUBPROTOCOL = "foxglove.websocket.v1"
PENDING_MAX = 20_000          # emitted, not yet converted (counted as dropped past it)
LAZY_S = 0.1                  # what is not a sample waits this long at most for a sample's flush
CLIENT_BUFFER = 4 * 1024 * 1024
MESSAGE_DATA, SERVICE_RESPONSE = 1, 3                   # server -> client (binary)
CLIENT_MESSAGE, SERVICE_REQUEST = 1, 2                  # client -> server (binary)
INFO, ERROR = 0, 2                                      # status levels


def _ws_frame(data: str | bytes) -> bytes:
    """One final WebSocket frame: text (opcode 1) or binary (2)."""
    if isinstance(data, str):
        data, op = data.encode(), 0x81
    else:
        op = 0x82
    n = len(data)
    if n < 126:
        return bytes((op, n)) + data
    if n < 1 << 16:
        return struct.pack("!BBH", op, 126, n) + data
    return struct.pack("!BBQ", op, 127, n) + data


class _Client:
    def __init__(self, ws: ServerConnection):
        self.ws = ws
        self.subs: dict[int, int] = {}          # channel id -> subscription id
        self.pubs: dict[int, str] = {}          # its channel id -> the request (client publish)
        self.c = Counters(frames=0, dropped=0)
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
        self.last: dict[int, tuple[int, Out]] = {}      # channel id -> its last message
        self.c = Counters(messages=0, dropped=0, origin_refused=0, calls=0, call_errors=0,
                          published=0, publish_errors=0, bad_frames=0)
        self.url = ""
        self._loop: asyncio.AbstractEventLoop | None = None
        self._handover = Handover(self._flush, LAZY_S, PENDING_MAX)

    # ---- any thread: queue and wake the loop once
    def emit(self, msg: dict) -> None:
        """Queue ``msg``; a sample wakes the loop (once for all that come meanwhile).
        The rest (command records, log lines, link and behaviors' states) ride with the
        next sample's flush, or go with a tick every LAZY_S while they come: no wake-up
        of their own while samples flow."""
        if not self._handover.put(msg, msg.get("t") != "s"):
            self.c.add("dropped")

    def _on_commands(self, key: str, obj: JSON) -> None:
        got, _bad = records.unpack(key, obj)
        for res, rec in got:
            self.emit({"t": "c", "r": res, "m": rec})

    # ---- the loop
    def _flush(self) -> None:
        got = self._handover.take()
        n = 0
        for m in got:
            for out in self._convert(m):
                self._publish(out)
                n += 1
        self.c.add("messages", n)
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
        self.last[cid] = (ns, out)
        for client in list(self.clients):
            sub = client.subs.get(cid)
            if sub is not None:                  # (encoded only for a subscriber)
                self._data(client, sub, ns, out.data)

    def _data(self, client: _Client, sub: int, ns: int, data: bytes) -> None:
        transport = client.ws.transport
        if transport is not None and transport.get_write_buffer_size() > CLIENT_BUFFER:
            client.c.add("dropped")
            self.c.add("dropped")
            return
        client.out.append(struct.pack("<BIQ", MESSAGE_DATA, sub, ns) + data)

    @staticmethod
    def _send(client: _Client, frame: str | bytes) -> None:
        """One frame now, after those waiting (in order, never waits)."""
        client.out.append(frame)
        FoxServer._write(client)

    @staticmethod
    def _write(client: _Client) -> None:
        """The frames waiting, in one write to the socket (one WebSocket frame each, as
        the protocol has it: one system call per message cost more than the rest of the
        server's loop). A server's frames are whole and unmasked (RFC 6455 5.2), no
        extension is negotiated (compression=None): their header is written here, not by
        websockets' frame objects, which cost more than the rest per message."""
        frames, client.out = client.out, []
        ws = client.ws
        if not frames or ws.state is not State.OPEN or ws.transport is None:
            return
        client.c.add("frames", len(frames))
        ws.transport.write(b"".join(_ws_frame(f) for f in frames))

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
            "capabilities": ["clientPublish", "services"], "supportedEncodings": ["json"],
            "metadata": {"clientPublish": json.dumps(
                {topic: cmds.REQUESTS[name] for topic, name in cmds.TOPICS.items()})},
            "sessionId": str(int(time.time()))}))
        await ws.send(json.dumps({"op": "advertise", "channels": [
            self._channel(t, *ch) for t, ch in self.channels.items()]}))
        await ws.send(json.dumps({"op": "advertiseServices", "services": [
            {"id": i + 1, "name": name, "type": f"esair.{name}",
             "request": {"encoding": "json", "schemaName": req["title"],
                         "schemaEncoding": "jsonschema", "schema": json.dumps(req)},
             "response": {"encoding": "json", "schemaName": cmds.RESPONSE["title"],
                          "schemaEncoding": "jsonschema", "schema": json.dumps(cmds.RESPONSE)}}
            for i, (name, req) in enumerate(cmds.REQUESTS.items())]}))
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
                        ns, out = self.last[cid]
                        self._data(client, sub, ns, out.data)
            elif op == "unsubscribe":
                gone = {int(i) for i in m["subscriptionIds"]}
                client.subs = {c: s for c, s in client.subs.items() if s not in gone}
            elif op == "advertise":                  # client publish: its channels
                for ch in m["channels"]:
                    topic, name = ch["topic"], cmds.TOPICS.get(ch["topic"])
                    if name is None or ch.get("encoding") != "json":
                        raise ValueError(f"client channel {topic!r} ({ch.get('encoding')}): "
                                         f"this server takes JSON on {', '.join(cmds.TOPICS)}")
                    client.pubs[int(ch["id"])] = name
            elif op == "unadvertise":
                for i in m["channelIds"]:
                    client.pubs.pop(int(i), None)
            else:
                raise ValueError(f"unknown op {op!r}")
        except (ValueError, KeyError, TypeError, AttributeError) as exc:
            self.c.add("bad_frames")
            self._status(client, ERROR, f"bad request: {exc}")

    def _status(self, client: _Client, level: int, message: str) -> None:
        self._send(client, json.dumps({"op": "status", "level": level, "message": message}))

    async def _binary(self, client: _Client, frame: bytes) -> None:
        """A service call or a client-published message; each waits for the RS's
        answer before the client's next frame is read (one at a time per client)."""
        if len(frame) >= 13 and frame[0] == SERVICE_REQUEST:
            await self._service(client, frame)
        elif len(frame) >= 5 and frame[0] == CLIENT_MESSAGE:
            await self._published(client, frame)
        else:
            self.c.add("bad_frames")
            self._status(client, ERROR, f"bad request: a binary frame of {len(frame)} bytes "
                                        f"with opcode {frame[:1].hex() or 'none'}")

    async def _published(self, client: _Client, frame: bytes) -> None:
        (cid,) = struct.unpack_from("<I", frame, 1)
        name = client.pubs.get(cid)
        try:
            if name is None:
                raise BridgeError(f"client channel {cid} is not advertised")
            topic = f"/esair/{name}"
            assert self._loop is not None and self.bridge is not None
            ok = await self._loop.run_in_executor(None, cmds.run, self.bridge, name,
                                                  cmds.parse(frame[5:]))
        except BridgeError as exc:
            self.c.add("publish_errors")
            self._status(client, ERROR, f"{f'/esair/{name}' if name else 'publish'}: {exc}")
            return
        self.c.add("published")
        self._status(client, INFO, f"{topic}: {json.dumps(ok)}")

    async def _service(self, client: _Client, frame: bytes) -> None:
        sid, call, n = struct.unpack_from("<III", frame, 1)
        encoding, payload = frame[13:13 + n], frame[13 + n:]
        names = list(cmds.REQUESTS)
        self.c.add("calls")
        try:
            if not 0 < sid <= len(names):
                raise BridgeError(f"no service {sid}")
            assert self._loop is not None and self.bridge is not None
            ok = await self._loop.run_in_executor(None, cmds.run, self.bridge, names[sid - 1],
                                                  cmds.parse(payload))
        except BridgeError as exc:
            self.c.add("call_errors")
            self._send(client, json.dumps({"op": "serviceCallFailure", "serviceId": sid,
                                           "callId": call, "message": str(exc)}))
            return
        out = json.dumps({"ok": ok}).encode()
        self._send(client, struct.pack("<BIII", SERVICE_RESPONSE, sid, call, len(encoding))
                   + encoding + out)

    # ---- life cycle
    async def serve(self, ready: Callable[[str], None], stop: asyncio.Event) -> None:
        self._loop = self._handover.loop = asyncio.get_running_loop()
        self.bridge = Bridge(self.endpoint, self.emit, who=cmds.PRINCIPAL,
                             on_commands=self._on_commands)
        bridge = self.bridge
        bridge.showing = lambda: bool(self.clients)     # behaviors' states: while one looks
        bridge.link_bar = False         # /link is the link's state at each change only
        await self._loop.run_in_executor(None, bridge.start)
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

