"""A runtime (with its control endpoint) without a ``security:`` section does not
import ``cryptography`` (remote.registration imports it only where a certificate is used)."""

import subprocess
import sys
from pathlib import Path

import pytest

from tests.support.std import MODES, free_endpoint

pytestmark = pytest.mark.slow

HERE = Path(__file__).resolve().parents[2]  # the checkout: tests.support imports from here

SCRIPT = """
import sys
from esair_std import Runtime
rt = Runtime({"robot": "t", "behaviors": {"sink": {"class": "tests.support.comps:Sink"}}},
             mode=sys.argv[1], endpoint=sys.argv[2], control=True)
rt.start()
try:
    rt.put("sink", "x")
    print("esair_std.remote.center" in sys.modules, "cryptography" in sys.modules)
finally:
    rt.stop()
"""


@pytest.mark.parametrize("mode", MODES)
def test_runtime_without_security_does_not_import_cryptography(mode):
    out = subprocess.run([sys.executable, "-c", SCRIPT, mode, free_endpoint()], cwd=HERE,
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["True", "False"]


def test_a_certificate_check_does_import_it():
    code = ("import sys; from esair_std.remote.registration import prove_with_cert\n"
            "print('cryptography' in sys.modules)\n"
            "try:\n    prove_with_cert('t', 'a', 'no.pem', 'no.key')\n"
            "except OSError:\n    pass\n"
            "print('cryptography' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], cwd=HERE, capture_output=True,
                         text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["False", "True"]
