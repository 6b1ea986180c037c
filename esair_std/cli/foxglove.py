"""``esair std foxglove``: the running robot, live, in Foxglove or Lichtblick
(docs/foxglove.md)."""

from __future__ import annotations

import asyncio
import os
import signal
import sys

import click

from esair_min import sigs
from esair_min.cli.pipes import friendly

from .client import default_endpoint
from .shared_options import exposure, insecure_option

DEFAULT_LISTEN = "127.0.0.1:8765"


@click.command("foxglove")
@click.option("-e", "--endpoint", default=None, metavar="tcp/HOST:PORT",
              help="The runtime's control endpoint (default tcp/127.0.0.1:7447, or "
                   "$ESAIR_STD_ENDPOINT).")
@click.option("--listen", default=DEFAULT_LISTEN, show_default=True, metavar="HOST:PORT",
              help="Where the Foxglove WebSocket server listens. Any address but loopback "
                   "needs client certificates (--client-ca). Port 0: any free port.")
@click.option("--tls-cert", default=None, metavar="PEM", help="Serve wss:// with this "
              "certificate (e.g. from `esair std certs`).")
@click.option("--tls-key", default=None, metavar="PEM", help="Its private key.")
@click.option("--client-ca", default=None, metavar="PEM",
              help="Require client certificates signed by this CA.")
@click.option("--allow-origin", "origins", multiple=True, metavar="ORIGIN",
              help="A browser origin allowed to connect besides none (native apps), e.g. "
                   "https://app.foxglove.dev (repeat).")
@insecure_option()
@friendly
def foxglove_cmd(endpoint: str | None, listen: str, tls_cert: str | None, tls_key: str | None,
                 client_ca: str | None, origins: tuple[str, ...], insecure: bool) -> None:
    """Serve the robot live over the Foxglove WebSocket protocol (the channels of
    `esair std record`): open Foxglove or Lichtblick on the printed ws:// URL. Reads as
    the principal `foxglove`; its services command as the principal `operator` (only
    where the deployment's `allow` grants it) and STOP and release the robot. Prints the
    URL on its first line and serves until Ctrl-C."""
    import logging

    from ..hmi.auth import LOOPBACK
    from ..record.foxserver import FoxServer
    from .hmi import split_listen, tls_context

    host, port = split_listen(listen)
    tls = tls_context(tls_cert, tls_key, client_ca)
    if host not in LOOPBACK and not client_ca:
        # the protocol has no login: only client certificates tell who connects
        exposure(f"listening on {host}", "client certificates (--tls-cert, --tls-key, "
                 "--client-ca) or an SSH tunnel to 127.0.0.1", insecure)
    logging.basicConfig(level=logging.WARNING, format="foxglove: %(message)s")
    logging.getLogger("websockets").setLevel(logging.ERROR)
    server = FoxServer(endpoint or default_endpoint(), host, port, tls, list(origins))

    async def main() -> None:
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            if not sigs.ignored(sig):
                loop.add_signal_handler(sig, stop.set)

        def ready(url: str) -> None:
            click.echo(url)
            sys.stdout.flush()
        await server.serve(ready, stop)
    asyncio.run(main())
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)      # as `esair std run`: no interpreter finalisation under Zenoh's threads
