"""What ``esair std hmi`` and ``esair std foxglove`` share once their options are read
(the options: shared_options.server_options): the listen address, the TLS context, and
serving until Ctrl-C or SIGTERM."""

from __future__ import annotations

import asyncio
import os
import signal
import ssl
import sys
from typing import Awaitable, Callable

import click

from esair_min import sigs


def split_listen(listen: str, default: str) -> tuple[str, int]:
    from ..errors import ControlError
    host, sep, port = listen.rpartition(":")
    host = host.strip("[]")
    if not sep or not host or not port.isdigit() or not 0 <= int(port) <= 65535:
        raise ControlError(f"--listen {listen!r} is not HOST:PORT (e.g. {default})")
    return host, int(port)


def tls_context(cert: str | None, key: str | None, client_ca: str | None) -> ssl.SSLContext | None:
    from ..errors import ControlError
    if not cert and not client_ca:
        return None
    if not cert or not key:
        raise ControlError("TLS needs --tls-cert and --tls-key (and --client-ca for client "
                           "certificates)")
    ctx = ssl.create_default_context(ssl.Purpose.CLIENT_AUTH)
    try:
        ctx.load_cert_chain(cert, key)
        if client_ca:
            ctx.load_verify_locations(client_ca)
            ctx.verify_mode = ssl.CERT_REQUIRED
    except (OSError, ssl.SSLError) as exc:
        raise ControlError(f"TLS: {exc}") from None
    return ctx


def quiet_logs(prefix: str) -> None:
    """Warnings and errors on stderr as ``prefix: message``; websockets' own only errors."""
    import logging
    logging.basicConfig(level=logging.WARNING, format=f"{prefix}: %(message)s")
    logging.getLogger("websockets").setLevel(logging.ERROR)


def serve(run: Callable[[Callable[[str], None], asyncio.Event], Awaitable[None]]) -> None:
    """``await run(ready, stop)`` until Ctrl-C or SIGTERM sets ``stop``; ``ready(url)``
    prints the URL on stdout's first line. Ends the process (as `esair std run`: no
    interpreter finalisation under Zenoh's threads)."""
    async def main() -> None:
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            if not sigs.ignored(sig):           # a background job keeps its ignore
                loop.add_signal_handler(sig, stop.set)

        def ready(url: str) -> None:
            click.echo(url)
            sys.stdout.flush()
        await run(ready, stop)
    asyncio.run(main())
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)
