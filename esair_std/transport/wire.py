"""STD's wire in one place: the request/reply envelope, its one error encoder and
decoder, and the one verb table every endpoint serves with.

A request is a JSON object (transport/codec.py); its verb is the last part of the key
(``esair/<robot>/ctl/<verb>``: the control endpoint) or its ``op`` field (``bs/<name>``,
``rs/<entry>``: an agent's endpoints). Every reply is a JSON object, one of

    {"ok": value}
    {"error": message, "type": ErrorType}                       # any other StdError
    {"error": message, "type": ErrorType, "resource": r, "reason": why}
                                                # CommandError and ResourceLost

``type`` names one of :data:`ERRORS` (an error of another class travels as its nearest
base among them; anything that is no StdError as ``StdError``, "internal error: ...").
:func:`error` is the only place a reply of an error is built, :func:`result` the only
place one is read: whichever side raised it, the asker raises the same class with the
same words (the CLI raises what an agent raised).

:class:`Verbs` is the table an endpoint answers from: a request that is garbage or names
a verb the table does not hold gets one ``ControlError`` ("bad request: ...", or the
table's own "unknown ..." words) and changes nothing; a handler's StdError is its reply;
a bug in a handler is an "internal error" reply, never a silent timeout.
"""

from __future__ import annotations

import logging
from typing import Callable, Protocol

from ..errors import (CommandError, ComponentError, ControlError, DeployError, Refused,
                      ResourceLost, StdError, TransportError)
from ..counters import Counters
from .codec import JSON, JSONObject

log = logging.getLogger("esair_std.transport")

#: the error classes a reply can name, by name (the ``type`` field)
ERRORS: dict[str, type[StdError]] = {cls.__name__: cls for cls in (
    StdError, Refused, CommandError, ResourceLost, ComponentError, ControlError,
    TransportError, DeployError)}

Reply = JSONObject
Answer = Callable[[Reply], None]


def ok(value: JSON = None) -> Reply:
    """A reply that carries ``value``."""
    return {"ok": value}


def _wire_class(exc: StdError) -> type[StdError]:
    for cls in type(exc).__mro__:
        if ERRORS.get(cls.__name__) is cls:
            return cls
    return StdError              # unreachable: StdError is in every StdError's MRO


def error(exc: BaseException) -> Reply:
    """The one error encoder: the reply that makes the asker raise ``exc`` again."""
    if not isinstance(exc, StdError):
        return {"error": f"internal error: {type(exc).__name__}: {exc}", "type": "StdError"}
    out: Reply = {"error": str(exc), "type": _wire_class(exc).__name__}
    if isinstance(exc, (CommandError, ResourceLost)):
        out.update(resource=exc.resource, reason=exc.reason)
    return out


def failure(value: JSON | StdError, resource: str) -> StdError:
    """What a resource host's ``on_done(False, value)`` means: its StdError, or a
    CommandError of ``resource`` in the driver's own words."""
    return value if isinstance(value, StdError) else CommandError(resource, str(value))


def exception(reply: Reply, resource: str = "?") -> StdError:
    """The one error decoder: the exception an error reply stands for. A CommandError or
    ResourceLost without its resource (a short reply) is ``resource``'s, ``error`` its
    reason; a ``type`` this side does not know is a StdError."""
    message = str(reply.get("error"))
    cls = ERRORS.get(str(reply.get("type")), StdError)
    if cls is CommandError or cls is ResourceLost:
        res, why = reply.get("resource"), reply.get("reason")
        if isinstance(res, str) and isinstance(why, str):
            return cls(res, why)
        return cls(resource, message)
    return cls(message)


def result(reply: Reply, resource: str = "?") -> JSON:
    """The ``ok`` value of a reply, or its error raised (:func:`exception`)."""
    if "error" in reply:
        raise exception(reply, resource)
    return reply.get("ok")


class Request(Protocol):
    """One request being served, by a query (transport.bus.Request) or by a sample
    (transport.calls.SampleServer): its key, its body (None: garbage, ``error`` says
    why) and ``reply(obj)`` once, from any thread."""

    @property
    def key(self) -> str: ...
    @property
    def body(self) -> JSONObject | None: ...
    @property
    def error(self) -> str: ...
    def reply(self, obj: Reply) -> None: ...


Handler = Callable[[JSONObject], JSON]  # a decoded body: read after its checks
LaterHandler = Callable[[JSONObject, Answer], None]


class Verbs:
    """One endpoint's verb table. ``add(verb, fn)``: ``fn(body)`` returns the ok value
    (or raises); ``later(verb, fn)``: ``fn(body, answer)`` answers once, now or from
    another thread (a reply it cannot give at once). ``unknown`` is the words for a verb
    not in the table (``{verb!r}`` is filled in). Counts ``bad_requests`` (garbage, an
    unknown verb)."""

    def __init__(self, unknown: str = "unknown verb {verb!r}"):
        self.unknown = unknown
        self._now: dict[str, Handler] = {}
        self._later: dict[str, LaterHandler] = {}
        self.c = Counters(bad_requests=0)

    def add(self, verb: str, fn: Handler) -> None:
        self._now[verb] = fn

    def later(self, verb: str, fn: LaterHandler) -> None:
        self._later[verb] = fn

    def __contains__(self, verb: object) -> bool:
        return verb in self._now or verb in self._later

    def names(self) -> list[str]:
        return sorted([*self._now, *self._later])

    def serve(self, verb: object, body: JSONObject | None, error_: str,
              answer: Answer) -> None:
        """Answer one request (``body`` None: garbage, ``error_`` says why)."""
        if body is None:
            self.c.add("bad_requests")
            answer(error(ControlError(f"bad request: {error_}")))
            return
        fn = self._later.get(verb) if isinstance(verb, str) else None
        if fn is None:
            answer(self.answer(verb, body))
            return
        try:
            fn(body, answer)
        except Exception as exc:  # noqa: BLE001 - told to the asker, not lost
            answer(self._failed(verb, exc))

    def answer(self, verb: object, body: JSONObject | None, error_: str = "") -> Reply:
        """The reply of a verb that answers at once (``verb`` as the request named it:
        not a string, it is unknown)."""
        fn = self._now.get(verb) if isinstance(verb, str) else None
        try:
            if body is None:
                raise ControlError(f"bad request: {error_}")
            if fn is None:
                raise ControlError(self.unknown.format(verb=verb))
            return ok(fn(body))
        except Exception as exc:  # noqa: BLE001 - every failure is a reply
            return self._failed(verb, exc)

    def _failed(self, verb: object, exc: Exception) -> Reply:
        if isinstance(exc, ControlError) and exc.message.startswith(
                ("bad request", self.unknown.split("{", 1)[0])):
            self.c.add("bad_requests")
        elif not isinstance(exc, StdError):
            log.error("verb %s: %s: %s", verb, type(exc).__name__, exc, exc_info=exc)
        return error(exc)

    def request(self, verb_of: Callable[[Request], object]) -> Callable[[Request], None]:
        """A handler for Bus.serve: serves each request by the verb ``verb_of`` finds."""
        def handle(req: Request) -> None:
            body = req.body
            verb = verb_of(req) if body is not None else ""
            self.serve(verb, body, req.error, req.reply)
        return handle


def op_of(req: Request) -> object:
    """The verb of an agent's request: its ``op`` field, as sent."""
    body = req.body
    return body.get("op") if body is not None else None

