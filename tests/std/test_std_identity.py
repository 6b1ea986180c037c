"""The RS's own identity check of remote agents (esair_std.remote.registration): the layer
that still stops a stranger when the Zenoh ACL lets it through."""

import time

import pytest

from esair_std.errors import Refused
from esair_std.remote.registration import Verifier, prove_with_cert, prove_with_password
from esair_std.transport.tls_certs import make_certs


@pytest.fixture(scope="module")
def pki(tmp_path_factory):
    d = tmp_path_factory.mktemp("pki")
    make_certs(d / "good", clients=["locate", "intruder"])
    make_certs(d / "other", clients=["locate"])
    (d / "users.txt").write_text("locate:s3cret\n")
    return d


def _cert(pki, who="locate", ca="good", robot="lab", name="locate"):
    return prove_with_cert(robot, name, pki / ca / f"{who}.pem", pki / ca / f"{who}.key")


def _refused(verifier, proof, message, name="locate", **ident):
    with pytest.raises(Refused) as exc:
        verifier.check("lab", name, proof, **ident)
    assert str(exc.value) == message


def test_a_good_certificate_proof_is_accepted_once(pki):
    v = Verifier(ca=pki / "good" / "ca.pem")
    proof = _cert(pki)
    v.check("lab", "locate", proof, cn="locate")
    _refused(v, proof, "locate: proof of identity replayed", cn="locate")


def test_certificate_proofs_that_fail(pki):
    v = Verifier(ca=pki / "good" / "ca.pem")
    _refused(v, _cert(pki, ca="other"), "locate: certificate not signed by this robot's CA",
             cn="locate")
    _refused(v, _cert(pki, who="intruder"), "locate: certificate is not 'locate''s", cn="locate")
    _refused(v, _cert(pki, robot="other"), "locate: bad signature on the proof of identity",
             cn="locate")
    forged = {**_cert(pki, who="intruder"), "cert": (pki / "good" / "locate.pem").read_text()}
    _refused(v, forged, "locate: bad signature on the proof of identity", cn="locate")
    _refused(v, _cert(pki), "locate: this robot does not know locate by a certificate",
             user="locate")
    old = _cert(pki)
    old["t"] -= 3600
    with pytest.raises(Refused, match="proof of identity too old"):
        v.check("lab", "locate", old, cn="locate")


@pytest.mark.parametrize("proof, message", [
    (None, "locate: registration without a proof of identity"),
    ({"kind": "cert"}, "locate: malformed proof of identity"),
    ({"kind": "cert", "t": "now", "nonce": "x", "cert": "garbage", "sig": "!!"},
     "locate: malformed proof of identity"),
    ([1, 2], "locate: registration without a proof of identity"),
])
def test_garbage_proofs_are_refused(pki, proof, message):
    if isinstance(proof, dict) and proof.get("t") == "now":
        proof = {**proof, "t": time.time()}
    _refused(Verifier(ca=pki / "good" / "ca.pem"), proof, message, cn="locate")


def test_password_proofs(pki):
    v = Verifier(users=pki / "users.txt")
    v.check("lab", "locate", prove_with_password("lab", "locate", "locate", "s3cret"),
            user="locate")
    _refused(v, prove_with_password("lab", "locate", "locate", "guess"),
             "locate: wrong password in the proof of identity", user="locate")
    _refused(v, prove_with_password("lab", "locate", "mallory", "x"),
             "locate: this robot does not know locate by that login", user="locate")
