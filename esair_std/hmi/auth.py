"""Who may do what on the HMI: viewers read, operators command.

- Listening on a loopback address with no password configured, every page is an
  operator (the person at this computer).
- With passwords (a file of ``user:scrypt$...`` lines written by ``esair std
  hmi-password``, or ``$ESAIR_HMI_PASSWORD`` for the user ``operator``, hashed when
  read and not kept), a page is a viewer until it logs in.
- With TLS client certificates (``--client-ca``), a page whose certificate the CA signed
  is an operator; the TLS handshake refuses any other.
- Any other address without a password or client certificates: refused at start, unless
  ``--insecure`` (a warning; every page is an operator, as on loopback).

Hashes are scrypt (hashlib) with a random salt; comparisons in constant time.
"""

from __future__ import annotations

import base64
import hashlib
import hmac
import os
import secrets
from collections.abc import Mapping
from pathlib import Path

from ..counters import Counters
from ..errors import StdError

N, R, P = 2 ** 14, 8, 1
LOOPBACK = ("127.0.0.1", "::1", "localhost")
TOKENS_MAX = 1024


class AuthError(StdError):
    """A password file or listen address that cannot be used."""


def hash_password(password: str, salt: bytes | None = None) -> str:
    salt = salt or os.urandom(16)
    h = hashlib.scrypt(password.encode(), salt=salt, n=N, r=R, p=P, dklen=32)
    return "scrypt${}${}${}${}${}".format(N, R, P, base64.b64encode(salt).decode(),
                                          base64.b64encode(h).decode())


def check_password(password: str, stored: str) -> bool:
    try:
        kind, n, r, p, salt, h = stored.split("$")
        if kind != "scrypt":
            return False
        got = hashlib.scrypt(password.encode(), salt=base64.b64decode(salt), n=int(n),
                             r=int(r), p=int(p), dklen=len(base64.b64decode(h)))
    except (ValueError, TypeError):
        return False
    return hmac.compare_digest(got, base64.b64decode(h))


def read_password_file(path: str | Path) -> dict[str, str]:
    users = {}
    try:
        text = Path(path).read_text()
    except OSError as exc:
        raise AuthError(f"password file {path}: {exc.strerror}") from None
    for n, line in enumerate(text.splitlines(), 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        user, sep, stored = line.partition(":")
        if not sep or not user or not stored.startswith("scrypt$") or stored.count("$") != 5:
            raise AuthError(f"{path}:{n}: expected USER:scrypt$... (written by "
                            "`esair std hmi-password`)")
        users[user] = stored
    return users


class Auth:
    def __init__(self, host: str, users: dict[str, str] | None = None,
                 client_certs: bool = False, insecure: bool = False):
        self.users = dict(users or {})
        self.client_certs = client_certs
        # insecure: another address without a login, asked for (every page an operator)
        self.open = (host in LOOPBACK or insecure) and not self.users and not client_certs
        if not (host in LOOPBACK or self.users or client_certs or insecure):
            raise AuthError(f"listening on {host} reaches other computers: it needs a login "
                            "(--password-file or $ESAIR_HMI_PASSWORD) or TLS client "
                            "certificates (--client-ca), or --insecure to go without")
        self._tokens: dict[str, str] = {}
        self.c = Counters(failed_logins=0)        # shown in /status.json

    @classmethod
    def from_options(cls, host: str, password_file: str | None, env: Mapping[str, str],
                     client_certs: bool = False, insecure: bool = False) -> "Auth":
        users = read_password_file(password_file) if password_file else {}
        plain = env.get("ESAIR_HMI_PASSWORD")
        if plain:
            users.setdefault("operator", hash_password(plain))
        return cls(host, users, client_certs, insecure)

    def first_role(self) -> str:
        """The role of a page before any login."""
        return "operator" if self.open or self.client_certs else "viewer"

    def login(self, user: object, password: object) -> str | None:
        """A session token for a right user and password, else None (counted)."""
        stored = self.users.get(user) if isinstance(user, str) else None
        if stored is None or not isinstance(password, str) or not check_password(password,
                                                                                  stored):
            self.c.add("failed_logins")
            return None
        assert isinstance(user, str)                 # stored is None for any other type
        return self._token(user)

    def resume(self, token: object) -> str | None:
        """The user of a token this server gave out, else None."""
        return self._tokens.get(token) if isinstance(token, str) else None

    def _token(self, user: str) -> str:
        if len(self._tokens) >= TOKENS_MAX:
            self._tokens.pop(next(iter(self._tokens)))
        tok = secrets.token_urlsafe(24)
        self._tokens[tok] = user
        return tok
