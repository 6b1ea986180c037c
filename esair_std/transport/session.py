"""One function opens every Zenoh session: peer mode, explicit endpoints, multicast
scouting off (containers and CI have no multicast), so a session finds exactly the
peers it is told about; shared memory off. ``options`` carries extra Zenoh config
(TLS, ACL, ...) as {json5 path: JSON value} pairs, added by the security layer."""

from __future__ import annotations

import json
import os
import re
from typing import Mapping

import zenoh

from ..errors import TransportError


# Zenoh routes every message a session receives on its "rx" pool of threads, 2 by default.
# A message published with BLOCK congestion control (a sensor's samples) that must go on
# towards a peer whose link is cut waits there for room until Zenoh closes that transport
# (the lease), holding its thread: with two such, the whole session routed nothing for
# ~5 s. The control center, which routes for every agent, gets more threads (a test with
# 16: 0 of 12 cuts stalled its local puts, against 5 of 12 with the default).
HUB_RUNTIME = "(rx: (worker_threads: 16))"
hub_runtime_set = False      # True: this process set ZENOH_RUNTIME (its children must not)


#: where in Zenoh's Rust source an error was raised (" at /root/.cargo/.../orchestrator.rs:388."):
#: nothing a user can act on, so it is cut from the messages that quote Zenoh
RUST_PLACE = re.compile(r"\s+at\s+\S+\.rs:\d+\.?$")


def zenoh_message(exc: BaseException) -> str:
    """A Zenoh error's text without the place in Zenoh's source it came from."""
    return RUST_PLACE.sub("", str(exc).strip())


def hub_runtime() -> None:
    """Give this process's Zenoh the control center's thread pools (before its first
    session; a ZENOH_RUNTIME set by the user wins)."""
    global hub_runtime_set
    if "ZENOH_RUNTIME" not in os.environ:
        os.environ["ZENOH_RUNTIME"] = HUB_RUNTIME
        hub_runtime_set = True


def open_session(listen: list[str] | None = None, connect: list[str] | None = None,
                 options: Mapping[str, object] | None = None) -> "zenoh.Session":
    cfg = zenoh.Config()
    try:
        cfg.insert_json5("mode", '"peer"')
        cfg.insert_json5("scouting/multicast/enabled", "false")
        # gossip runs over the sessions already open (no multicast): agents that connect
        # to the runtime learn of each other and connect directly (the data flow).
        cfg.insert_json5("scouting/gossip/enabled", "true")
        # no shared memory: STD's messages are small JSON, and zenoh's SHM transport would
        # copy every message of 3 KB or more between local processes into a 16 MiB pool
        # that the receiver maps too (an agent given twenty 50 KB puts grew from 27.7 to
        # 47.9 MB RSS; 28.4 MB with SHM off); off, an agent also has 0.2-0.5 MB less RSS
        # at rest, and big messages go over the link in batches, as between computers.
        cfg.insert_json5("transport/shared_memory/enabled", "false")
        if listen:
            cfg.insert_json5("listen/endpoints", json.dumps(list(listen)))
        if connect:
            cfg.insert_json5("connect/endpoints", json.dumps(list(connect)))
            # keep trying to reach the runtime if it is not up yet (agents, the CLI)
            cfg.insert_json5("connect/timeout_ms", "2000")
        for path, value in (options or {}).items():
            cfg.insert_json5(path, json.dumps(value))
    except Exception as exc:  # noqa: BLE001 - zenoh raises ZError for bad endpoints / config
        raise TransportError(f"bad session config: {zenoh_message(exc)}") from None
    try:
        return zenoh.open(cfg)
    except Exception as exc:  # noqa: BLE001 - e.g. the endpoint is in use
        where = ", ".join(listen or connect or [])
        raise TransportError(f"cannot open a Zenoh session on {where}: {zenoh_message(exc)}") from None


def _parts(locator: str) -> tuple[str, str, str]:
    """``(protocol, host, port)`` of a Zenoh locator (``tcp/[::1]:7447#iface=lo`` ->
    ``('tcp', '::1', '7447')``); its metadata and config cut."""
    proto, _, rest = locator.partition("/")
    rest = rest.split("#", 1)[0].split("?", 1)[0]
    host, _, port = rest.rpartition(":")
    return proto, host.strip("[]"), port


def endpoint_hosts(endpoint: str) -> set[str]:
    """The addresses ``endpoint``'s host stands for (a name resolved once, as Zenoh does
    when it dials it); the host as written when it does not resolve."""
    _, host, port = _parts(endpoint)
    hosts = {host}
    if host in ("", "0.0.0.0", "::"):       # "any address": a dial there reaches loopback
        return hosts | {"127.0.0.1", "::1"}
    if ":" in host or re.fullmatch(r"[\d.]+", host):
        return hosts                           # an address already (an agent's usual case:
                                               # it imports no socket module for it)
    import socket
    try:
        hosts |= {str(info[4][0]) for info in socket.getaddrinfo(host, port or None)}
    except (OSError, UnicodeError):
        pass
    return hosts


def peer_at(session: "zenoh.Session", endpoint: str, hosts: set[str]) -> str | None:
    """The Zenoh id of the peer this session is linked to at ``endpoint`` (``hosts``: its
    addresses, :func:`endpoint_hosts`); None while there is no such link. Other peers a
    session meets through gossip are not it, whatever they answer."""
    proto, _, port = _parts(endpoint)
    for link in session.info.links():
        p, h, pt = _parts(str(link.dst))
        if p == proto and pt == port and h in hosts:
            return str(link.zid)
    return None


def check_endpoint(endpoint: str) -> str:
    """``tcp/HOST:PORT`` (or another Zenoh locator) as given; a clear error otherwise."""
    proto, sep, rest = endpoint.partition("/")
    if not sep or not proto or ":" not in rest:
        raise TransportError(f"endpoint {endpoint!r} is not of the form tcp/HOST:PORT")
    return endpoint
