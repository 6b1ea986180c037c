"""``esair std certs DIR``: a test CA and certificates for a TLS control endpoint."""

from __future__ import annotations

import sys

import click

from esair_min.errors import EsairError


@click.command("certs")
@click.argument("folder", metavar="DIR")
@click.option("-c", "--client", "clients", multiple=True, metavar="NAME",
              help="Make a client certificate whose common name is NAME: one per remote "
                   "agent (repeat the option). The ACL knows an agent by this name.")
@click.option("--host", "hosts", multiple=True, metavar="HOST",
              help="A name or IP address agents connect to (repeat); it goes into the "
                   "server certificate (localhost and 127.0.0.1 always do).")
@click.option("--days", type=click.IntRange(min=1), default=365, show_default=True,
              help="Validity of every certificate.")
def certs(folder: str, clients: tuple[str, ...], hosts: tuple[str, ...], days: int) -> None:
    """Make a test certificate authority (ca.pem, ca.key), a certificate for the control
    center (server.pem, server.key) and one per --client (NAME.pem, NAME.key) in DIR.

    \b
    The deployment of the control center then says:
      endpoint: tls/HOST:7447
      security: {ca: DIR/ca.pem, cert: DIR/server.pem, key: DIR/server.key,
                 agents: {NAME: {cn: NAME}}}
    and a remote agent runs with
      esair std agent --connect tls/HOST:7447 --ca DIR/ca.pem \\
          --cert DIR/NAME.pem --key DIR/NAME.key NAME module:Class
    Keep the .key files secret (they are written with mode 0600)."""
    from esair_std.transport.tls_certs import make_certs

    try:
        made = make_certs(folder, clients=clients, hosts=hosts, days=days)
    except EsairError as exc:
        click.echo(f"error: {exc}", err=True)
        sys.exit(1)
    for name, pem in made.items():
        click.echo(f"{name:<12} {pem}  {pem.with_suffix('.key')}")
