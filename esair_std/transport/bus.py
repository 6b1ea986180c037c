"""A small API over one Zenoh session: JSON requests with a timeout, queryables whose
handlers may answer later from another thread, publishers, subscribers, liveliness.

Callbacks given here run on Zenoh's threads: they must copy and return (the callers in
modes/ only enqueue or answer at once; user code never runs on them). Queryable and
subscriber callbacks run directly on Zenoh's network thread (``indirect=False``):
zenoh-python's default hands each one to a Python thread of its own first, which cost
50-100 us a hop here (bench/std_goals.py); since ours only copy, enqueue or answer, the hand-off
buys nothing. Liveliness callbacks, which may take locks of the runtime, keep it. The
thread states of Zenoh's threads are kept between callbacks (threadstate.py).
"""

from __future__ import annotations

import contextlib
import logging
import threading
from typing import (Any, Callable, Literal, Mapping, Protocol, TypeVar, overload,
                    runtime_checkable)

import zenoh

from ..counters import Counters
from ..errors import TransportError
from . import codec, keys, threadstate, wire
from .codec import JSON, JSONObject
from .session import endpoint_hosts, open_session, peer_at

log = logging.getLogger("esair_std.transport")
_T = TypeVar("_T", bound="Declared")


@runtime_checkable
class Declared(Protocol):
    """What the bus declared on its session (a queryable, a subscriber, a publisher, a
    token, a querier): undeclared when the bus closes."""

    def undeclare(self) -> None: ...


class Request:
    """One received query: ``body`` (decoded JSON or None if garbage), ``error`` (why it
    could not be decoded), ``reply(obj)`` once, from any thread."""

    __slots__ = ("_query", "body", "error", "key", "_done", "_express")

    def __init__(self, query: zenoh.Query, express: bool = False):
        self._query = query
        self._express = express
        self.key = str(query.key_expr)
        self._done = False
        self.body: JSONObject | None = None
        self.error = ""
        payload = query.payload
        try:
            self.body = codec.decode_request(payload.to_bytes() if payload is not None else b"{}")
        except TransportError as exc:
            self.error = exc.message

    def reply(self, obj: JSON) -> None:
        if self._done:
            return
        self._done = True
        try:
            try:
                data = codec.encode(obj)
            except TransportError as exc:
                data = codec.encode(wire.error(exc))
            self._query.reply(self._query.key_expr, data, express=self._express)
        except Exception as exc:  # noqa: BLE001 - the asker is gone; nothing to tell
            log.debug("reply on %s not sent: %s", self.key, exc)
        finally:
            self._query.drop()     # a held query stalls the asker until its timeout


class Route:
    """Whether some queryable answers ``key`` now (Zenoh's matching status), kept in
    ``ready`` (an Event: wait on it, never poll)."""

    def __init__(self, session: zenoh.Session, key: str):
        self.ready = threading.Event()
        self._querier = session.declare_querier(key)
        self._listener = self._querier.declare_matching_listener(self._status)
        # zenoh's stub types matching_status a bool; it is a MatchingStatus
        if self._querier.matching_status.matching:  # type: ignore[attr-defined]
            self.ready.set()

    def _status(self, status: zenoh.MatchingStatus) -> None:
        if status.matching:
            self.ready.set()
        else:
            self.ready.clear()

    def undeclare(self) -> None:
        with contextlib.suppress(Exception):            # the session is closing
            self._listener.undeclare()
        with contextlib.suppress(Exception):
            self._querier.undeclare()


def _zid(reply: zenoh.Reply) -> str | None:
    """The Zenoh id of the session that sent ``reply`` (None when Zenoh does not say)."""
    who = reply.replier_id
    return str(who.zid) if who is not None else None


class Bus:
    """One Zenoh session. ``runtime``: the endpoint of the runtime this bus was opened to
    ask (a client, the HMI, an agent): a control request (``esair/<robot>/ctl/<verb>``,
    keys.ctl) then takes its answer from the peer linked at that endpoint only. Another
    runtime of the same robot name that the session meets through gossip (a stray one
    on the same network, or on a port the runtime had before) is never the one that
    answers: without this, 2 of 6 `esair std inspect` answered from such a peer."""

    def __init__(self, listen: list[str] | None = None, connect: list[str] | None = None,
                 options: Mapping[str, object] | None = None, runtime: str | None = None):
        self.session = open_session(listen, connect, options)
        self.runtime = runtime
        self._runtime_hosts = endpoint_hosts(runtime) if runtime else set()
        self._decl: list[Declared] = []
        self._pub_of: dict[str, tuple[zenoh.Publisher, ...]] = {}     # key -> its publishers (``undeclare``)
        self._lock = threading.Lock()
        self.closed = False
        # foreign_answers: control answers from a peer not at ``runtime``, ignored (the
        # HMI's executor threads and pollers ask at once: added under the counters' lock)
        self.c = Counters(foreign_answers=0)

    def _keep(self, obj: _T) -> _T:
        with self._lock:
            self._decl.append(obj)
        return obj

    # request/reply
    def request(self, key: str, body: JSONObject, timeout: float,
                express: bool = False) -> Any:
        """The first reply's JSON, or None when nobody answers (no queryable / timeout).
        ``express``: the request is sent at once, never held to share a batch (a command
        to an actuator: docs/std-papaman.md, item 7). A control request of a bus opened
        with ``runtime`` counts only the answer of the peer at that endpoint."""
        data = codec.encode(body)
        only = self.runtime if self.runtime and keys.is_ctl(key) else None
        try:
            # asked of every queryable, every answer delivered, when one is to be picked:
            # Zenoh's defaults ask only the queryable it deems best and keep one answer
            # per key, either of which may be the stray's
            pick = only is not None
            replies = self.session.get(
                key, payload=data, timeout=max(0.001, timeout), express=express,
                target=zenoh.QueryTarget.ALL if pick else None,
                consolidation=zenoh.ConsolidationMode.NONE if pick else None)
            for reply in replies:
                ok = reply.ok
                if ok is None:
                    continue
                if only is not None and _zid(reply) != peer_at(
                        self.session, only, self._runtime_hosts):
                    self.c.add("foreign_answers")
                    if self.c["foreign_answers"] == 1:
                        log.warning("an answer on %s came from a peer that is not the "
                                    "runtime at %s: ignored (another runtime of this "
                                    "robot's name on the network?)", key, only)
                    continue
                return codec.decode(ok.payload.to_bytes())
        except TransportError:
            raise
        except Exception as exc:  # noqa: BLE001 - session closed etc.
            raise TransportError(f"request on {key} failed: {exc}") from None
        return None

    def runtime_robot(self) -> str | None:
        """The robot name the runtime at ``runtime`` answers a ping with; None when it
        does not answer (asked twice: the session may still be connecting)."""
        for timeout in (2.0, 3.0):
            r = self.request("esair/*/ctl/ping", {}, timeout)
            if isinstance(r, dict) and isinstance(r.get("ok"), dict) and "robot" in r["ok"]:
                return str(r["ok"]["robot"])
        return None

    def route(self, key: str) -> Route:
        """A :class:`Route` to ``key`` (undeclared when the bus closes)."""
        return self._keep(Route(self.session, key))

    def serve(self, key: str, handler: Callable[[Request], None],
              express: bool = False) -> zenoh.Queryable[None]:
        """``handler(request)`` on Zenoh's network thread: it must enqueue or answer.
        ``express``: replies are sent at once, never held to share a batch."""
        def cb(query: zenoh.Query) -> None:
            threadstate.keep()
            try:
                handler(Request(query, express))
            except Exception as exc:  # noqa: BLE001 - never let a handler kill the thread
                log.error("handler on %s: %s", key, exc)
        return self._keep(self.session.declare_queryable(
            key, zenoh.handlers.Callback(cb, indirect=False)))

    # pub/sub
    @overload
    def publisher(self, key: str, drop: bool = False, raw: Literal[False] = False,
                  express: bool | None = None) -> Callable[[JSON], None]: ...
    @overload
    def publisher(self, key: str, drop: bool = False, *, raw: Literal[True],
                  express: bool | None = None) -> Callable[[bytes], None]: ...

    def publisher(self, key: str, drop: bool = False, raw: bool = False,
                  express: bool | None = None) -> Callable[[bytes], None] | Callable[[JSON], None]:
        """``put(obj)`` for ``key``. ``drop``: never wait for a congested link (for
        messages whose loss the sender notices by a timeout), sent at once (express,
        unless ``express=False``: a stream of many small messages, batched by Zenoh, costs
        far less and so is dropped far less when the computer is busy).
        ``raw``: ``put(data)`` takes the bytes already encoded (codec.encode). A table of
        publishers per peer gives them back with :meth:`undeclare` when the peer goes."""
        if drop:
            pub = self._keep(self.session.declare_publisher(
                key, congestion_control=zenoh.CongestionControl.DROP,
                express=True if express is None else express))
        else:
            pub = self._keep(self.session.declare_publisher(
                key, congestion_control=zenoh.CongestionControl.BLOCK,
                express=bool(express)))

        with self._lock:
            self._pub_of[key] = self._pub_of.get(key, ()) + (pub,)
        if raw:
            return pub.put

        def put(obj: JSON) -> None:
            pub.put(codec.encode(obj))
        return put

    def undeclare(self, key: str) -> None:
        """Undeclare the publishers made for ``key`` (their ``put`` fails after)."""
        with self._lock:
            pubs = self._pub_of.pop(key, ())
            for pub in pubs:
                if pub in self._decl:
                    self._decl.remove(pub)
        for pub in pubs:
            with contextlib.suppress(Exception):        # the session is closing
                pub.undeclare()

    def subscribe(self, key: str, callback: Callable[..., None], *,
                  with_key: bool = False,
                  garbage: Callable[[str], None] | None = None) -> zenoh.Subscriber[None]:
        """``callback(obj)`` (or ``callback(key, obj)``) on Zenoh's network thread for
        each sample's decoded JSON; garbage (not UTF-8 JSON, over the size cap) is dropped
        and told to ``garbage(why)``, else logged."""
        def cb(sample: zenoh.Sample) -> None:
            threadstate.keep()
            try:
                try:
                    obj = codec.decode(sample.payload.to_bytes())
                except TransportError as exc:
                    if garbage is None:
                        raise
                    garbage(exc.message)
                    return
                if with_key:
                    callback(str(sample.key_expr), obj)
                else:
                    callback(obj)
            except Exception as exc:  # noqa: BLE001
                log.error("subscriber on %s: %s", key, exc)
        return self._keep(self.session.declare_subscriber(
            key, zenoh.handlers.Callback(cb, indirect=False)))

    def unsubscribe(self, sub: object) -> None:
        """Undeclare ``sub`` (what :meth:`subscribe` gave; anything else is left)."""
        if not isinstance(sub, Declared):
            return
        with self._lock:
            if sub in self._decl:
                self._decl.remove(sub)
        try:
            sub.undeclare()
        except Exception:  # noqa: BLE001
            pass

    # liveliness
    def token(self, key: str) -> zenoh.LivelinessToken:
        return self._keep(self.session.liveliness().declare_token(key))

    def watch_alive(self, key: str,
                    callback: Callable[[str, bool], None]) -> zenoh.Subscriber[None]:
        def cb(sample: zenoh.Sample) -> None:
            try:
                callback(str(sample.key_expr), sample.kind == zenoh.SampleKind.PUT)
            except Exception as exc:  # noqa: BLE001
                log.error("liveliness on %s: %s", key, exc)
        return self._keep(self.session.liveliness().declare_subscriber(key, cb, history=True))

    def alive(self, key: str, timeout: float = 1.0) -> list[str]:
        """The keys of the live tokens matching ``key``."""
        out = []
        for reply in self.session.liveliness().get(key, timeout=timeout):
            if reply.ok is not None:
                out.append(str(reply.ok.key_expr))
        return out

    def close(self) -> None:
        if self.closed:
            return
        self.closed = True
        with self._lock:
            decl, self._decl = self._decl, []
        for d in reversed(decl):
            try:
                d.undeclare()
            except Exception:  # noqa: BLE001
                pass
        try:
            self.session.close()
        except Exception:  # noqa: BLE001
            pass
