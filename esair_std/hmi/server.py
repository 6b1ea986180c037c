"""The web side of the HMI: static files and one WebSocket on one port (``websockets``).

Each page gets the bridge's ``hello`` and then every message the bridge emits: the
loop writes one encoded frame to every open page's socket at once (``broadcast``: no
queue, task or wake-up per page); a page whose socket has more than ``PAGE_BUFFER``
bytes not yet taken by its browser cannot keep up and loses the frame, counted per page
and in ``/status.json`` (``dropped``); nobody else waits for it. Frames from a page are small JSON
objects (``op``); anything else — not JSON, not an object, an unknown ``op``, a field of
the wrong type, a binary frame — is a bad frame: counted, answered with an error,
nothing changes. Commands need the operator role (auth.py). The WebSocket handshake is
refused (403) when the browser's ``Origin`` is not this server's own: a page of another
site cannot drive the robot through the user's browser.
"""

from __future__ import annotations

import asyncio
import json
import logging
import mimetypes
import ssl as _ssl
import time
from http import HTTPStatus
from pathlib import Path
from typing import TYPE_CHECKING, Callable, TypeAlias, TypeVar, cast

from websockets.asyncio.server import ServerConnection, broadcast, serve
from websockets.datastructures import Headers
from websockets.exceptions import ConnectionClosed
from websockets.http11 import Request, Response

from ..counters import Counters
from ..errors import StdError
from ..heap import settle
from ..plurals import counted
from ..transport.codec import JSON, JSONObject
from .auth import Auth
from .bridge import Bridge, BridgeError, took
from .commanded import PoseBook
from .handover import Handover

if TYPE_CHECKING:  # pragma: no cover
    from ..record.tap import Tap

# the MCAP library (mcap, lz4, zstandard: ~3 MB of this process's memory) is imported
# when the page records or replays, not before

log = logging.getLogger("esair_std.hmi")
STATIC = Path(__file__).resolve().parent / "static"
PAGE_BUFFER = 256 * 1024   # bytes written to a page's socket and not yet sent: past it, frames are dropped
LAZY_S = 0.05               # a command's record waits this long at most for a sample's frame to ride in
LAZY = ("ran", "link")      # ... and the link bar's update (its reply ages, 4 a second)
PENDING_MAX = 10_000        # messages emitted and not yet handed to the pages (counted as dropped past it)
MAX_FRAME = 64 * 1024       # bytes of one frame from a page
CSP = ("default-src 'self'; img-src 'self' data:; style-src 'self' 'unsafe-inline'; "
       "connect-src 'self'; frame-ancestors 'none'")
OPERATOR_OPS = {"cmd", "stop", "release", "add", "remove", "restart", "record"}
LOAD_MAX = 50_000           # samples of a recording sent to a page for replay

#: a page's frame's ``id``, echoed in its answer
Ident: TypeAlias = "int | str | None"
_T = TypeVar("_T")
_J = TypeVar("_J", bound=JSON)


def load_static(root: Path = STATIC) -> dict[str, tuple[bytes, str]]:
    files = {}
    for path in sorted(root.rglob("*")):
        if path.is_file() and not path.name.startswith("."):
            ctype = mimetypes.guess_type(path.name)[0] or "application/octet-stream"
            if path.suffix == ".js":
                ctype = "text/javascript"
            if ctype.startswith("text/"):
                ctype += "; charset=utf-8"
            files["/" + path.relative_to(root).as_posix()] = (path.read_bytes(), ctype)
    files["/"] = files["/index.html"]
    return files


def _compact(value: JSON) -> str:
    """A command as the log shows it: JSON without spaces, as the page sends it."""
    return json.dumps(value, separators=(",", ":"))


def _unnamed(why: str, res: str) -> str:
    """A refusal's reason without the resource's name it starts with (the log's line
    names it already)."""
    return why[len(res) + 2:] if why.startswith(res + ": ") else why


class BadFrame(Exception):
    pass


class Page:
    def __init__(self, ws: ServerConnection, role: str):
        self.ws = ws
        self.role = role
        self.user = ""
        self.c = Counters(dropped=0)   # frames this page lost (/status.json: per page)
        self.hidden = False         # in the background: no samples (op "view")


def _port(ws: ServerConnection) -> int | None:
    """The page's port on its browser's side (None once its socket is gone)."""
    peer = ws.remote_address
    return peer[1] if isinstance(peer, tuple) and len(peer) > 1 else None


def _field(frame: JSONObject, name: str, kind: type[_T]) -> _T:
    v = frame.get(name)
    if not isinstance(v, kind) or isinstance(v, bool) and kind is not bool:
        raise BadFrame(f"field {name!r} missing or of the wrong type")
    return v


class HmiServer:
    def __init__(self, endpoint: str, host: str, port: int, auth: Auth,
                 tls: _ssl.SSLContext | None = None, who: str = "hmi",
                 record_dir: str | Path = "."):
        self.endpoint, self.host, self.port = endpoint, host, port
        self.auth = auth
        self.tls = tls
        self.who = who
        self.files = load_static()
        self.pages: set[Page] = set()
        self.bridge: Bridge | None = None
        self.url = ""
        self.book = PoseBook()     # what the robot was last told: the pose a page shows
        self.record_dir = Path(record_dir)
        self.tap: Tap | None = None
        self.c = Counters(pages=0, frames=0, bad_frames=0, refused=0, dropped=0,
                          origin_refused=0, commands=0, command_errors=0, batches=0,
                          held=0)       # samples not sent to pages in the background
        self._stop: asyncio.Event | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._handover = Handover(self._flush, LAZY_S, PENDING_MAX)   # emitted, not yet sent

    # ---- fan-out (any thread -> the loop)
    def emit(self, msg: JSONObject) -> None:
        """Hand ``msg`` to the pages. The caller (Zenoh's thread, the bridge's poller)
        only appends it to a bounded list; the loop is woken once for all that came
        meanwhile, encodes them once, and writes every page the same frame (``{"t": "b",
        "m": [...], "f": when}``): at 50 Hz of samples and more, one loop wake-up and
        one WebSocket frame per batch, not per sample. A command's record (``ran``: the
        pose and the sliders, which a person reads) does not wake the loop: it rides
        with the next sample's frame, or goes with the loop's lazy tick (every LAZY_S
        while such messages come; the first after a quiet spell wakes the loop to start
        it), so a stream of commands costs no wake-up and no frame of its own while
        samples flow; so does the link bar's update (a lost link shows within LAZY_S
        more)."""
        tap = self.tap
        if tap is not None:
            tap.put(msg)
        if not self._handover.put(msg, msg.get("t") in LAZY):
            self.c.add("dropped")

    def _flush(self) -> None:
        got = self._handover.take()
        msgs: list[JSON] = []
        for m in got:
            if m.get("t") == "ran":               # a command any sender got through
                shown = self.book.ran(str(m["r"]), m["v"],
                                      cast("float | None", m.get("at")) or time.time())
                if shown is None:
                    continue
                m = shown
            msgs.append(m)
        if not msgs or not self.pages:         # nobody to encode them for
            return
        self.c.add("batches")
        # f: when it left this process's queue (the page splits sample -> pixel at it)
        f = round(time.time(), 4)
        shown = [p for p in self.pages if not p.hidden]
        if shown:
            self._send(shown, json.dumps({"t": "b", "f": f, "m": msgs}, separators=(",", ":")))
        hidden = [p for p in self.pages if p.hidden]
        if hidden:                          # the same without the samples
            rest = [m for m in msgs if cast(JSONObject, m).get("t") != "s"]
            self.c.add("held", (len(msgs) - len(rest)) * len(hidden))
            if rest:
                self._send(hidden, json.dumps({"t": "b", "f": f, "m": rest}, separators=(",", ":")))

    def _send(self, pages: Page | list[Page], text: str) -> None:
        """Write ``text`` to these pages' sockets now (in order with every other frame
        of each page); a page whose socket holds more than PAGE_BUFFER bytes not yet
        sent loses it (counted)."""
        if isinstance(pages, Page):
            pages = [pages]
        ready = []
        for page in pages:
            transport = page.ws.transport
            if transport is not None and transport.get_write_buffer_size() > PAGE_BUFFER:
                page.c.add("dropped")
                self.c.add("dropped")
            else:
                ready.append(page.ws)
        if ready:
            broadcast(ready, text)

    def status(self) -> JSONObject:
        pages = list(self.pages)
        return {"counters": {**self.c.snapshot(), "open_pages": len(pages),
                             "hidden_pages": sum(p.hidden for p in pages),
                             **self.auth.c.snapshot()},
                # each open page: its role, whether hidden, the frames it lost, and the
                # port it came from (which page is which, for its owner)
                "pages": [{"role": p.role, "hidden": p.hidden, "port": _port(p.ws),
                           **p.c.snapshot()} for p in pages],
                "bridge": {**self.bridge.counters()} if self.bridge else {}}

    # ---- HTTP
    def _http(self, connection: ServerConnection, request: Request) -> Response | None:
        path = request.path.split("?", 1)[0]
        if path == "/ws":
            origin = request.headers.get("Origin")
            host = request.headers.get("Host", "")
            scheme = "https" if self.tls else "http"
            if origin is not None and origin != f"{scheme}://{host}":
                self.c.add("origin_refused")
                log.warning("WebSocket from origin %s refused (this server is %s://%s)",
                            origin, scheme, host)
                return connection.respond(HTTPStatus.FORBIDDEN, "origin refused\n")
            return None
        if path == "/status.json":
            body, ctype = json.dumps(self.status()).encode(), "application/json"
        elif path in self.files:
            body, ctype = self.files[path]
        else:
            return connection.respond(HTTPStatus.NOT_FOUND, "not found\n")
        headers = Headers([("Content-Type", ctype), ("Content-Length", str(len(body))),
                           ("Cache-Control", "no-cache"), ("Content-Security-Policy", CSP),
                           ("X-Content-Type-Options", "nosniff")])
        return Response(200, "OK", headers, body)

    # ---- one page
    async def _page(self, ws: ServerConnection) -> None:
        page = Page(ws, self.auth.first_role())
        self.pages.add(page)
        self.c.add("pages")
        assert self.bridge is not None
        hello = dict(self.bridge.hello(), role=page.role, commanded=self.book.hello(time.time()),
                     recording=self.recording_state(),
                     login=bool(self.auth.users) and page.role != "operator")
        self._send(page, json.dumps(hello, separators=(",", ":")))
        try:
            async for frame in ws:
                self.c.add("frames")
                try:
                    await self._frame(page, frame)
                except BadFrame as exc:
                    self.c.add("bad_frames")
                    self._reply(page, None, False, f"bad frame: {exc}")
        except ConnectionClosed:
            pass
        finally:
            self.pages.discard(page)

    def _reply(self, page: Page, ident: Ident, ok: bool, value: JSON,
               logged: bool = False) -> None:
        """The answer to a page's frame; ``logged``: its failure is in the log of every
        page already (the page adds no line of its own)."""
        msg: JSONObject = {"t": "ack", "id": ident, "ok": ok}
        msg["result" if ok else "error"] = value
        if logged:
            msg["logged"] = True
        self._send(page, json.dumps(msg, separators=(",", ":")))

    async def _frame(self, page: Page, frame: str | bytes) -> None:
        if not isinstance(frame, str):
            raise BadFrame("binary frames are not understood")
        try:
            obj = json.loads(frame)
        except ValueError:
            raise BadFrame("not JSON") from None
        if not isinstance(obj, dict) or not isinstance(obj.get("op"), str):
            raise BadFrame("expected an object with an 'op'")
        op, ident = obj["op"], obj.get("id")
        if ident is not None and not isinstance(ident, (int, str)):
            raise BadFrame("field 'id' must be a number or a string")
        handler = getattr(self, f"op_{op}", None)
        if handler is None:
            raise BadFrame(f"unknown op {op!r}")
        if op in OPERATOR_OPS and page.role != "operator":
            self.c.add("refused")
            self._reply(page, ident, False, "viewers cannot command: log in as an operator")
            return
        await handler(page, ident, obj)

    async def _call(self, page: Page, ident: Ident, fn: Callable[..., _J], *args: object,
                    what: str = "") -> _J | None:
        """``fn(*args)`` on an executor's thread, answered to the page; a failure is one
        line in every page's log (``what: why``). Its value, or None when it failed."""
        loop = asyncio.get_running_loop()
        try:
            result = await loop.run_in_executor(None, fn, *args)
        except BridgeError as exc:
            self.c.add("command_errors")
            self._log("error", f"{what}: {exc}")
            self._reply(page, ident, False, str(exc), logged=True)
            return None
        self._reply(page, ident, True, result)
        return result

    def _log(self, level: str, text: str) -> None:
        self.emit({"t": "log", "level": level, "text": text, "ts": time.time()})

    # ---- ops
    async def op_ping(self, page: Page, ident: Ident, obj: JSONObject) -> None:
        self._reply(page, ident, True, obj.get("ts"))

    async def op_view(self, page: Page, ident: Ident, obj: JSONObject) -> None:
        """``{"op": "view", "hidden": bool}``: the page went to the background (another
        tab, a minimized window) or came back; a hidden page gets no samples (it would not
        draw them), everything else still (the link, the log, the components)."""
        page.hidden = _field(obj, "hidden", bool)
        self._reply(page, ident, True, page.hidden)

    async def op_login(self, page: Page, ident: Ident, obj: JSONObject) -> None:
        if "token" in obj:
            user = self.auth.resume(obj["token"])
            token = obj["token"] if user else None
        else:
            user = _field(obj, "user", str)
            token = self.auth.login(user, _field(obj, "password", str))
        if token is None:
            self._reply(page, ident, False, "wrong user or password")
            return
        page.role, page.user = "operator", str(user)
        self._reply(page, ident, True, {"role": "operator", "token": token, "user": user})

    def _command(self, res: str, command: JSON, answered: list[float]) -> JSON:
        """The bridge's command (an executor's thread), and when its answer came: a
        motion's start or STOP time, taken here, not after the loop's next turn."""
        assert self.bridge is not None
        r = self.bridge.command(res, command)
        answered.append(took(r))
        return r

    async def _through(self, res: str, command: JSON) -> tuple[bool, JSON]:
        """One command of this HMI through the bridge: ``(True, its answer)`` once it went
        through, shown as commanded at the time its answer came (its record may come
        first: commanded.py), or ``(False, why it was refused)``."""
        asked = self.book.asked(res, command)
        answered: list[float] = []
        try:
            r = await asyncio.get_running_loop().run_in_executor(
                None, self._command, res, command, answered)
        except BridgeError as exc:
            self.c.add("command_errors")
            return False, str(exc)
        finally:
            self.book.answered(asked)
        shown = self.book.sent(res, command, answered[0])
        if shown is not None:
            self.emit(shown)
        return True, r

    async def op_cmd(self, page: Page, ident: Ident, obj: JSONObject) -> None:
        """One command; its line in every page's log, refused or not (the refusing page
        shows the reason beside what it sent, app.js)."""
        res = _field(obj, "resource", str)
        if "command" not in obj:
            raise BadFrame("field 'command' missing")
        self.c.add("commands")
        what = f"{page.user or page.role}: {res} {_compact(obj['command'])}"
        ok, r = await self._through(res, obj["command"])
        if ok:
            self._log("info", f"{what} -> {_compact(r)}")
            self._reply(page, ident, True, r)
        else:
            self._log("error", f"{what} refused: {_unnamed(str(r), res)}")
            self._reply(page, ident, False, r, logged=True)

    def _principal(self, page: Page) -> str:
        """Who a page's STOP or release is from: ``hmi`` and the user logged in."""
        return f"{self.who}:{page.user}" if page.user else self.who

    async def op_stop(self, page: Page, ident: Ident, obj: JSONObject) -> None:
        """The runtime's latched STOP (docs/hmi.md): every motion stopped, every command
        refused until an operator releases it."""
        assert self.bridge is not None
        reason = obj.get("reason") or ""
        if not isinstance(reason, str):
            raise BadFrame("field 'reason' must be text")
        self.c.add("commands")
        r = await self._call(page, ident, self.bridge.ask, "stop",
                             {"who": self._principal(page), "reason": reason}, 10.0,
                             what="STOP")
        if r is not None:
            self.emit({"t": "log", "level": "warning", "ts": time.time(),
                       "text": f"STOP by {r['by']} at {r['at']}: every command refused "
                               f"until released"})

    async def op_release(self, page: Page, ident: Ident, obj: JSONObject) -> None:
        """Release the STOP (operators only: OPERATOR_OPS); it starts nothing."""
        assert self.bridge is not None
        r = await self._call(page, ident, self.bridge.ask, "release",
                             {"who": self._principal(page)}, 10.0, what="release")
        if r is not None:
            self.emit({"t": "log", "level": "warning", "ts": time.time(),
                       "text": f"released by {self._principal(page)} (STOP by {r['by']} at "
                               f"{r['at']})"})

    async def op_add(self, page: Page, ident: Ident, obj: JSONObject) -> None:
        body = {"name": _field(obj, "name", str), "class": _field(obj, "class", str),
                "uses": obj.get("uses") or {}, "options": obj.get("options") or {}}
        if not isinstance(body["uses"], dict) or not isinstance(body["options"], dict):
            raise BadFrame("fields 'uses' and 'options' must be objects")
        assert self.bridge is not None
        await self._call(page, ident, self.bridge.call, "add", body, 30.0,
                         what=f"add {body['name']}")

    async def op_remove(self, page: Page, ident: Ident, obj: JSONObject) -> None:
        assert self.bridge is not None
        name = _field(obj, "name", str)
        await self._call(page, ident, self.bridge.call, "remove", {"name": name}, 30.0,
                         what=f"remove {name}")

    async def op_restart(self, page: Page, ident: Ident, obj: JSONObject) -> None:
        assert self.bridge is not None
        name = _field(obj, "name", str)
        await self._call(page, ident, self.bridge.call, "restart", {"name": name}, 30.0,
                         what=f"restart {name}")

    async def op_record(self, page: Page, ident: Ident, obj: JSONObject) -> None:
        on = _field(obj, "on", bool)
        if on and self.tap is None:
            from ..record.tap import Tap
            name = time.strftime(f"esair-{self.bridge.robot if self.bridge else 'robot'}-%Y%m%d-%H%M%S.mcap")
            try:
                tap = Tap(self.record_dir / name)
            except StdError as exc:
                self._reply(page, ident, False, str(exc))
                return
            assert self.bridge is not None and self.bridge.bus is not None
            tap.listen(self.bridge.bus, self.bridge.robot)     # the commands too
            if self.bridge.latch.get("stopped"):      # STOPPED from its start: said first
                tap.put({"t": "latch", "v": self.bridge.latch})
            self.tap = tap
        elif not on and self.tap is not None:
            tap, self.tap = self.tap, None
            c = await asyncio.get_running_loop().run_in_executor(None, tap.stop)
            self.emit({"t": "log", "level": "info", "ts": time.time(),
                       "text": f"recorded {tap.path.name}: {counted(c['written'], 'sample')} and "
                               f"{counted(c['commands'], 'command')}, {c['dropped']} dropped"})
        state = self.recording_state()
        self._reply(page, ident, True, state)
        self.emit(state)

    def recording_state(self) -> JSONObject:
        tap = self.tap
        return {"t": "recording", "on": tap is not None, "file": tap.path.name if tap else ""}

    async def op_recordings(self, page: Page, ident: Ident, obj: JSONObject) -> None:
        files = sorted(self.record_dir.glob("*.mcap"), key=lambda p: p.stat().st_mtime)
        self._reply(page, ident, True, [{"file": p.name, "bytes": p.stat().st_size}
                                        for p in files])

    async def op_load(self, page: Page, ident: Ident, obj: JSONObject) -> None:
        name = _field(obj, "file", str)
        path = self.record_dir / name
        if "/" in name or not name.endswith(".mcap") or not path.is_file():
            self._reply(page, ident, False, f"no recording {name!r}")
            return

        def load() -> list[JSON]:
            from ..record.mcapio import read_samples
            out: list[JSON] = []
            for topic, seq, t, value in read_samples(path):
                out.append([topic, seq, t, value])
                if len(out) >= LOAD_MAX:
                    break
            return out
        try:
            samples = await asyncio.get_running_loop().run_in_executor(None, load)
        except StdError as exc:
            self._reply(page, ident, False, str(exc))
            return
        self._reply(page, ident, True, {"file": name, "samples": samples})

    # ---- life cycle
    async def serve(self, ready: Callable[[str], None], stop: asyncio.Event) -> None:
        self._loop = self._handover.loop = asyncio.get_running_loop()
        self.bridge = Bridge(self.endpoint, self.emit, who=self.who)
        # the link's counters and the behaviors' states are asked for while a page shows
        # them (a list of the set: taken at once, while the loop may change the set)
        self.bridge.showing = lambda: any(not p.hidden for p in list(self.pages))
        await self._loop.run_in_executor(None, self.bridge.start)
        # what start-up made lives as long as the process: out of the collector's way, so
        # a full collection walks only what came since (its pauses delay every sample)
        settle()
        try:
            async with serve(self._page, self.host, self.port, process_request=self._http,
                             ssl=self.tls, max_size=MAX_FRAME, server_header=None,
                             compression=None) as server:
                port = server.sockets[0].getsockname()[1]
                host = f"[{self.host}]" if ":" in self.host else self.host
                self.url = f"{'https' if self.tls else 'http'}://{host}:{port}/"
                ready(self.url)
                await stop.wait()
        finally:
            self.bridge.close()
            if self.tap is not None:
                self.tap.stop()
