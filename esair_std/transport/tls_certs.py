"""Test certificates for TLS / mTLS on the control endpoint (``esair std certs DIR``).

Made with the ``cryptography`` library rather than the openssl command: no external
program to find or version-check, the same result on every machine, and the extensions
rustls (Zenoh's TLS) insists on are set explicitly: the CA is a CA (basic constraints,
keyCertSign), the server certificate names its hosts as subject alternative names and
is for serverAuth, each client certificate is for clientAuth and carries the agent's
name as its common name (what Zenoh's access control matches, ``cert_common_names``).

Files written to DIR (keys are PKCS#8 PEM, mode 0600):
    ca.pem ca.key                      the test certificate authority
    server.pem server.key              the control center (listens; hosts as SANs)
    <client>.pem <client>.key          one pair per client name (agents)
This is a test CA: fine for a lab; a real site uses its own PKI with the same layout.
"""

from __future__ import annotations

import datetime as _dt
import ipaddress
import os
import re
from pathlib import Path

from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

from ..errors import StdError

NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")
DEFAULT_HOSTS = ("localhost", "127.0.0.1")


class CertError(StdError):
    """Certificates that cannot be made (bad name, folder not writable...)."""


def _key() -> ec.EllipticCurvePrivateKey:
    return ec.generate_private_key(ec.SECP256R1())


def _name(cn: str) -> x509.Name:
    return x509.Name([x509.NameAttribute(NameOID.ORGANIZATION_NAME, "ESAIR test CA"),
                      x509.NameAttribute(NameOID.COMMON_NAME, cn)])


def _builder(subject: str, issuer: x509.Name, key: ec.EllipticCurvePrivateKey,
             days: int) -> x509.CertificateBuilder:
    now = _dt.datetime.now(_dt.timezone.utc) - _dt.timedelta(minutes=5)
    return (x509.CertificateBuilder().subject_name(_name(subject)).issuer_name(issuer)
            .public_key(key.public_key()).serial_number(x509.random_serial_number())
            .not_valid_before(now).not_valid_after(now + _dt.timedelta(days=days)))


def _san(host: str) -> x509.GeneralName:
    try:
        return x509.IPAddress(ipaddress.ip_address(host))
    except ValueError:
        return x509.DNSName(host)


def _write(path: Path, cert: x509.Certificate, key: ec.EllipticCurvePrivateKey) -> None:
    path.with_suffix(".pem").write_bytes(cert.public_bytes(serialization.Encoding.PEM))
    key_path = path.with_suffix(".key")
    key_path.write_bytes(key.private_bytes(serialization.Encoding.PEM,
                                           serialization.PrivateFormat.PKCS8,
                                           serialization.NoEncryption()))
    os.chmod(key_path, 0o600)


def _check(kind: str, name: str) -> None:
    if not NAME.match(name) or name in ("ca", "server"):
        raise CertError(f"bad {kind} name {name!r}: letters, digits, '_', '.', '-' "
                        "(and not 'ca' or 'server')")


def make_certs(folder: str | Path, clients: list[str] | tuple[str, ...] = (),
               hosts: list[str] | tuple[str, ...] = (), days: int = 365,
               ca_name: str = "esair-test-ca") -> dict[str, Path]:
    """Write a test CA, a server certificate for ``hosts`` (plus localhost, 127.0.0.1)
    and one client certificate per name in ``clients``; returns {name: .pem path}."""
    for c in clients:
        _check("client", c)
    if days < 1:
        raise CertError(f"days must be at least 1, not {days}")
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise CertError(f"cannot create {folder}: {exc.strerror}") from None
    ca_key = _key()
    ca_subject = _name(ca_name)
    ca = (_builder(ca_name, ca_subject, ca_key, days)
          .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
          .add_extension(x509.KeyUsage(digital_signature=True, key_cert_sign=True, crl_sign=True,
                                       content_commitment=False, key_encipherment=False,
                                       data_encipherment=False, key_agreement=False,
                                       encipher_only=False, decipher_only=False), critical=True)
          .add_extension(x509.SubjectKeyIdentifier.from_public_key(ca_key.public_key()),
                         critical=False)
          .sign(ca_key, hashes.SHA256()))
    out = {}
    try:
        _write(folder / "ca", ca, ca_key)
        out["ca"] = folder / "ca.pem"
        all_hosts = list(dict.fromkeys([*DEFAULT_HOSTS, *hosts]))
        for name, usage in [("server", ExtendedKeyUsageOID.SERVER_AUTH),
                            *[(c, ExtendedKeyUsageOID.CLIENT_AUTH) for c in clients]]:
            key = _key()
            b = (_builder(all_hosts[0] if name == "server" else name, ca_subject, key, days)
                 .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
                 .add_extension(x509.ExtendedKeyUsage([usage]), critical=False)
                 .add_extension(x509.AuthorityKeyIdentifier.from_issuer_public_key(
                     ca_key.public_key()), critical=False))
            if name == "server":
                b = b.add_extension(x509.SubjectAlternativeName([_san(h) for h in all_hosts]),
                                    critical=False)
            cert = b.sign(ca_key, hashes.SHA256())
            _write(folder / name, cert, key)
            out[name] = folder / f"{name}.pem"
    except OSError as exc:
        raise CertError(f"cannot write into {folder}: {exc.strerror}") from None
    return out


def common_name(pem: str | Path) -> str:
    """The common name of a certificate file (what Zenoh ACL calls cert_common_name)."""
    cert = x509.load_pem_x509_certificate(Path(pem).read_bytes())
    value = cert.subject.get_attributes_for_oid(NameOID.COMMON_NAME)[0].value
    return value if isinstance(value, str) else value.decode()
