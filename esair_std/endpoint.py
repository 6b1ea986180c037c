"""A Zenoh endpoint as ESAIR writes it (``tcp/HOST:PORT``): the one check that a
deployment's ``endpoint`` and the command line's ``-e`` share, word for word.

Light on purpose (no pydantic, no Zenoh): every ``esair std`` command checks its ``-e``
before it does anything else.
"""

from __future__ import annotations

import ipaddress
import re

from esair_min.config.words import did_you_mean, quote, show

PROTOCOLS = ("tcp", "udp", "tls", "quic", "ws")
DEFAULT_ENDPOINT = "tcp/127.0.0.1:7447"
ENDPOINT_FORM = "PROTOCOL/HOST:PORT such as tcp/127.0.0.1:7447"
_HOST = re.compile(r"^(?=.{1,253}$)[A-Za-z0-9_]([A-Za-z0-9_-]*[A-Za-z0-9_])?"
                   r"(\.[A-Za-z0-9_]([A-Za-z0-9_-]*[A-Za-z0-9_])?)*$")


def endpoint_fault(text: str, key: str = "'endpoint'") -> str | None:
    """None for a locator the runtime can listen on, else one precise message that
    begins with ``key``."""
    proto, slash, rest = text.partition("/")
    if not slash:
        return f"{key} must be {ENDPOINT_FORM}, not {show(text)}"
    if proto == "unixsock-stream" and rest:
        return None
    if proto not in PROTOCOLS:
        hint = did_you_mean(proto, PROTOCOLS + ("unixsock-stream",))
        return (f"{key} protocol {quote(proto)} is not one of "
                f"{', '.join(PROTOCOLS)} or unixsock-stream{hint}")
    host, colon, port = rest.rpartition(":")
    if not colon or not host:
        return f"{key} needs a host and a port: {ENDPOINT_FORM}, not {show(text)}"
    if not port.isdigit() or int(port) > 65535:
        return f"{key} port must be a number from 0 to 65535, not {quote(port)}"
    if host.startswith("[") and host.endswith("]"):
        try:
            ipaddress.IPv6Address(host[1:-1])
            return None
        except ValueError:
            pass
    elif _HOST.match(host):
        return None
    hint = " (write an IPv6 address in brackets: [::1])" if ":" in host else ""
    return f"{key} host {quote(host)} is not an IP address or host name{hint}"


def reaches_beyond(endpoint: str) -> bool:
    """Whether other computers can reach ``endpoint`` (any address but loopback, a host
    name but ``localhost``; a Unix socket never)."""
    proto, _, rest = endpoint.partition("/")
    if proto == "unixsock-stream":
        return False
    host = rest.rpartition(":")[0].strip("[]") if ":" in rest else rest
    if host == "localhost":
        return False
    try:
        return not ipaddress.ip_address(host).is_loopback
    except ValueError:
        return True
