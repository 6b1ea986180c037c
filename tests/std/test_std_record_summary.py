"""`esair std record`'s closing line counts in words that agree with the numbers
(it read `32 samples and 1 commands on 1 channels`)."""

from __future__ import annotations

import subprocess
import sys

import pytest

from esair_std import Runtime
from esair_std.cli.hmi import counted
from esair_std.deploy.bundled import EXAMPLES
from esair_std.record import read_samples
from tests.support.std import ROOT, free_endpoint, wait_for


@pytest.mark.parametrize("n, text", [(0, "0 channels"), (1, "1 channel"), (2, "2 channels")])
def test_counted(n, text):
    assert counted(n, "channel") == text


def test_one_channel_is_one_channel(tmp_path):
    out = tmp_path / "wave.mcap"
    with Runtime(EXAMPLES / "lab" / "lab.yaml", mode="thread", endpoint=free_endpoint(),
                 control=True) as rt:
        with subprocess.Popen([sys.executable, "-m", "esair_min.cli", "std", "record", str(out),
                               "wave", "-e", rt.endpoint], cwd=ROOT, stderr=subprocess.PIPE,
                              text=True) as rec:          # its stderr closed after (no ResourceWarning)
            assert rec.stderr.readline() == f"recording to {out}\n"
            seq = rt.inspect("wave")["counters"]["seq"]
            wait_for(lambda: rt.inspect("wave")["counters"]["seq"] >= seq + 5, timeout=30,
                     what="five more wave samples")
            rec.terminate()
            assert rec.wait(timeout=30) == 0
            last = rec.stderr.read()
    n = len(list(read_samples(out)))
    assert n >= 1
    assert last == f"{out}: {counted(n, 'sample')} and 0 commands on 1 channel, " \
                   "0 dropped, 0 gaps in seq\n"
