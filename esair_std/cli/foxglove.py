"""``esair std foxglove``: the running robot, live, in Foxglove or Lichtblick
(docs/foxglove.md)."""

from __future__ import annotations

import click

from esair_min.cli.pipes import friendly

from .client import default_endpoint
from .shared_options import exposure, server_options

DEFAULT_LISTEN = "127.0.0.1:8765"


@click.command("foxglove")
@server_options(DEFAULT_LISTEN, "Where the Foxglove WebSocket server listens. Any address but "
                "loopback needs client certificates (--client-ca).",
                "Require client certificates signed by this CA.")
@click.option("--allow-origin", "origins", multiple=True, metavar="ORIGIN",
              help="A browser origin allowed to connect besides none (native apps), e.g. "
                   "https://app.foxglove.dev (repeat).")
@friendly
def foxglove_cmd(endpoint: str | None, listen: str, tls_cert: str | None, tls_key: str | None,
                 client_ca: str | None, insecure: bool, origins: tuple[str, ...]) -> None:
    """Serve the robot live over the Foxglove WebSocket protocol (the channels of
    `esair std record`): open Foxglove or Lichtblick on the printed ws:// URL. Reads as
    the principal `foxglove`; its services and client-publish topics command as the
    principal `operator` (only where the deployment's `allow` grants it) and STOP and
    release the robot. Prints the URL on its first line and serves until Ctrl-C."""
    from ..hmi.auth import LOOPBACK
    from ..record.foxserver import FoxServer
    from .serving import quiet_logs, serve, split_listen, tls_context

    host, port = split_listen(listen, DEFAULT_LISTEN)
    tls = tls_context(tls_cert, tls_key, client_ca)
    if host not in LOOPBACK and not client_ca:
        # the protocol has no login: only client certificates tell who connects
        exposure(f"listening on {host}", "client certificates (--tls-cert, --tls-key, "
                 "--client-ca) or an SSH tunnel to 127.0.0.1", insecure)
    quiet_logs("foxglove")
    serve(FoxServer(endpoint or default_endpoint(), host, port, tls, list(origins)).serve)
