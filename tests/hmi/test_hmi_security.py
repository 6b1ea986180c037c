"""Who may use the HMI, without a browser: an address other than loopback needs a login
or client certificates; passwords are stored hashed; with TLS client certificates only a
browser holding one of the CA's certificates connects, and it is an operator."""

from __future__ import annotations

import asyncio
import json
import os
import re
import signal
import ssl
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

import pytest
import websockets
from websockets.asyncio.client import connect as aconnect

from esair_std.hmi.auth import check_password
from tests.support.hmi import ROOT, esair_std


def test_another_address_without_login_is_refused():
    r = esair_std("hmi", "--listen", "0.0.0.0:0", "-e", "tcp/127.0.0.1:9")
    assert (r.returncode, r.stderr) == (
        1, "error: listening on 0.0.0.0 reaches other computers: it needs a login "
           "(--password-file or $ESAIR_HMI_PASSWORD) or TLS client certificates (--client-ca), "
           "or --insecure to go without\n")


def test_hmi_password_stores_a_hash(tmp_path):
    f = tmp_path / "users"
    r = subprocess.run([sys.executable, "-m", "esair_min.cli", "std", "hmi-password", str(f),
                        "ann"], input="s3cret\n", capture_output=True, text=True, cwd=ROOT)
    assert (r.returncode, r.stdout) == (0, f"ann: written to {f}\n")
    (line,) = f.read_text().splitlines()
    user, _, stored = line.partition(":")
    assert user == "ann" and stored.startswith("scrypt$") and "s3cret" not in line
    assert check_password("s3cret", stored) and not check_password("s3cret!", stored)
    assert os.stat(f).st_mode & 0o777 == 0o600
    f.write_text("ann:plain\n")
    r = esair_std("hmi", "--password-file", str(f), "-e", "tcp/127.0.0.1:9")
    assert (r.returncode, r.stderr) == (
        1, f"error: {f}:1: expected USER:scrypt$... (written by `esair std hmi-password`)\n")


@pytest.fixture
def tls_hmi(robot, tmp_path):
    """A second HMI on ``robot`` over TLS, requiring client certificates of a test CA."""
    certs = tmp_path / "certs"
    r = esair_std("certs", str(certs), "--client", "ann", "--host", "127.0.0.1")
    assert r.returncode == 0, r.stderr
    proc = subprocess.Popen(
        [sys.executable, "-m", "esair_min.cli", "std", "hmi", "-e", robot.endpoint, "--listen",
         "127.0.0.1:0", "--tls-cert", str(certs / "server.pem"), "--tls-key",
         str(certs / "server.key"), "--client-ca", str(certs / "ca.pem")],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    url = proc.stdout.readline().strip()
    assert re.fullmatch(r"https://127\.0\.0\.1:\d+/", url), proc.stderr.read()
    yield url, certs
    proc.send_signal(signal.SIGTERM)
    assert proc.wait(timeout=20) == 0, proc.stderr.read()
    assert proc.stderr.read() == ""


def test_tls_client_certificates_make_operators_and_keep_others_out(tls_hmi):
    url, certs = tls_hmi
    ws_url = url.replace("https://", "wss://") + "ws"
    ctx = ssl.create_default_context(cafile=str(certs / "ca.pem"))
    ctx.load_cert_chain(str(certs / "ann.pem"), str(certs / "ann.key"))
    bare = ssl.create_default_context(cafile=str(certs / "ca.pem"))   # no certificate

    # websockets' asyncio client, not its sync one: the sync client reads the TLS socket
    # on a thread of its own while the caller's thread writes the request, one OpenSSL
    # object used by two threads at once, which OpenSSL forbids; with TLS 1.3 (the
    # server's session tickets arrive as the request goes out) the request was lost now
    # and then, and the client gave up "timed out while waiting for handshake response"
    # (a bare server and that client here: 8 opens in 2500 hung; the asyncio client 0 in 1400)
    async def hello_of(ctx: ssl.SSLContext) -> dict:
        async with aconnect(ws_url, ssl=ctx, origin=url.rstrip("/")) as ws:
            return json.loads(await asyncio.wait_for(ws.recv(), 10))

    def hello(ctx: ssl.SSLContext) -> dict:
        # on a thread of its own: the session's Playwright runs an event loop on this one
        with ThreadPoolExecutor(1) as pool:
            return pool.submit(asyncio.run, hello_of(ctx)).result(timeout=60)

    hello_ = hello(ctx)
    assert (hello_["t"], hello_["role"], hello_["robot"]) == ("hello", "operator", "papaman")
    # TLS 1.3: the server refuses the missing certificate after the client's handshake,
    # so the refusal shows as the connection closed, before or after the HTTP upgrade,
    # and never with the page's first message
    refused = (ssl.SSLError, websockets.InvalidMessage, websockets.ConnectionClosed)
    with pytest.raises(refused):
        hello(bare)
