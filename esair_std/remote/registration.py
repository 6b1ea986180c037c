"""Who is registering: the RS's own check of a remote agent's identity.

Zenoh's access control (transport/security_config.py) already keeps agents to their keys; this
is the second, independent layer, so that a mistake in the ACL (or no ACL) still lets
nobody register under a name that is not theirs:

* with certificates, the agent signs ``esair-register|<robot>|<name>|<time>|<nonce>``
  with its private key and sends its certificate; the control center checks that the
  certificate was signed by the robot's CA, that its common name is the agent's name,
  that the signature is good and that the time is within ``MAX_AGE`` seconds;
* with user/password logins, the agent sends an HMAC-SHA256 of the same text keyed with
  its password; the control center recomputes it from its ``users`` file.

The proof is a small JSON object carried in the registration request (``proof``).
Each nonce is accepted once (replays within ``MAX_AGE`` are refused).

``cryptography`` is imported only where a certificate is used (a ``security:``
section with ``ca``/``cert``): a runtime without one does not load it (~9 MB RSS).
"""

from __future__ import annotations

import base64
import hashlib
import hmac
import os
import threading
import time
from collections import OrderedDict
from pathlib import Path


from ..errors import Refused
from ..transport.codec import JSONObject

MAX_AGE = 30.0


def _b64(b: bytes) -> str:
    return base64.b64encode(b).decode()


def _text(robot: str, name: str, t: float, nonce: str) -> bytes:
    return f"esair-register|{robot}|{name}|{t:.3f}|{nonce}".encode()


def prove_with_cert(robot: str, name: str, cert: str | Path, key: str | Path) -> JSONObject:
    """The proof an agent holding ``cert``/``key`` sends with its registration."""
    from cryptography.hazmat.primitives import hashes, serialization
    from cryptography.hazmat.primitives.asymmetric import ec

    t, nonce = time.time(), os.urandom(12).hex()
    private = serialization.load_pem_private_key(Path(key).read_bytes(), password=None)
    if not isinstance(private, ec.EllipticCurvePrivateKey):
        raise Refused(f"{key}: only EC keys are supported for registration proofs")
    sig = private.sign(_text(robot, name, t, nonce), ec.ECDSA(hashes.SHA256()))
    return {"kind": "cert", "t": t, "nonce": nonce, "cert": Path(cert).read_text(),
            "sig": _b64(sig)}


def prove_with_password(robot: str, name: str, user: str, password: str) -> JSONObject:
    t, nonce = time.time(), os.urandom(12).hex()
    mac = hmac.new(password.encode(), _text(robot, name, t, nonce), hashlib.sha256).digest()
    return {"kind": "user", "user": user, "t": t, "nonce": nonce, "mac": _b64(mac)}


class Verifier:
    """The control center's side: ``check(robot, name, proof, identity)``.

    ``identity`` is the deployment's entry for the agent (``cn`` or ``user``); ``ca`` and
    ``users`` are the files of the security section."""

    def __init__(self, ca: str | Path | None = None, users: str | Path | None = None):
        self._ca = None
        if ca:
            from cryptography import x509
            self._ca = x509.load_pem_x509_certificate(Path(ca).read_bytes())
        self._users = {}
        if users:
            for line in Path(users).read_text().splitlines():
                if ":" in line:
                    u, p = line.split(":", 1)
                    self._users[u.strip()] = p.strip()
        self._seen: OrderedDict[str, float] = OrderedDict()
        self._lock = threading.Lock()

    def check(self, robot: str, name: str, proof: object, cn: str | None = None,
              user: str | None = None) -> None:
        """Raise Refused unless ``proof`` shows the sender is agent ``name``."""
        if not isinstance(proof, dict) or proof.get("kind") not in ("cert", "user"):
            raise Refused(f"{name}: registration without a proof of identity")
        t, nonce = proof.get("t"), proof.get("nonce")
        if not isinstance(t, (int, float)) or not isinstance(nonce, str) or len(nonce) > 64:
            raise Refused(f"{name}: malformed proof of identity")
        if abs(time.time() - t) > MAX_AGE:
            raise Refused(f"{name}: proof of identity too old (clocks {time.time() - t:+.0f} s apart?)")
        text = _text(robot, name, t, nonce)
        if proof["kind"] == "cert":
            self._check_cert(name, proof, text, cn)
        else:
            self._check_user(name, proof, text, user)
        with self._lock:
            if nonce in self._seen:
                raise Refused(f"{name}: proof of identity replayed")
            self._seen[nonce] = t
            while len(self._seen) > 4096:
                self._seen.popitem(last=False)

    def _check_cert(self, name: str, proof: dict[str, object], text: bytes,
                    cn: str | None) -> None:
        if self._ca is None or cn is None:
            raise Refused(f"{name}: this robot does not know {name} by a certificate")
        from cryptography import x509
        from cryptography.exceptions import InvalidSignature
        from cryptography.hazmat.primitives import hashes
        from cryptography.hazmat.primitives.asymmetric import ec
        from cryptography.x509.oid import NameOID

        try:
            cert = x509.load_pem_x509_certificate(str(proof.get("cert", "")).encode())
            sig = base64.b64decode(str(proof.get("sig", "")), validate=True)
        except ValueError:
            raise Refused(f"{name}: malformed proof of identity") from None
        try:
            cert.verify_directly_issued_by(self._ca)
        except (ValueError, TypeError, InvalidSignature):
            raise Refused(f"{name}: certificate not signed by this robot's CA") from None
        now = time.time()
        if not (cert.not_valid_before_utc.timestamp() <= now <= cert.not_valid_after_utc.timestamp()):
            raise Refused(f"{name}: certificate expired or not yet valid")
        names = cert.subject.get_attributes_for_oid(NameOID.COMMON_NAME)
        if not names or names[0].value != cn:
            raise Refused(f"{name}: certificate is not {cn!r}'s")
        key = cert.public_key()
        if not isinstance(key, ec.EllipticCurvePublicKey):   # signs no ECDSA proof
            raise Refused(f"{name}: bad signature on the proof of identity")
        try:
            key.verify(sig, text, ec.ECDSA(hashes.SHA256()))
        except (InvalidSignature, TypeError, AttributeError):
            raise Refused(f"{name}: bad signature on the proof of identity") from None

    def _check_user(self, name: str, proof: dict[str, object], text: bytes,
                    user: str | None) -> None:
        if user is None or proof.get("user") != user or user not in self._users:
            raise Refused(f"{name}: this robot does not know {name} by that login")
        want = hmac.new(self._users[user].encode(), text, hashlib.sha256).digest()
        try:
            got = base64.b64decode(str(proof.get("mac", "")), validate=True)
        except ValueError:
            raise Refused(f"{name}: malformed proof of identity") from None
        if not hmac.compare_digest(want, got):
            raise Refused(f"{name}: wrong password in the proof of identity")
