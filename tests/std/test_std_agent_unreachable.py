"""``esair std agent --connect`` at an endpoint where no control center listens: one
``error:`` line a user can act on, exit status 1 — Zenoh's reason without the place in
Zenoh's Rust source it was raised (it read ``... Timeout! at
/root/.cargo/git/checkouts/zenoh-.../orchestrator.rs:388.``)."""

from __future__ import annotations

import subprocess
import sys

import pytest

from esair_std.transport.session import zenoh_message
from tests.support.std import ROOT, free_endpoint


def test_an_agent_with_no_control_center_says_so():
    ep = free_endpoint()                    # nothing listens there
    r = subprocess.run([sys.executable, "-m", "esair_min.cli", "std", "agent", "--connect", ep,
                        "--robot", "lab", "far", "tests.support.comps:Sink"], cwd=ROOT,
                       stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=60)
    assert (r.returncode, r.stdout) == (1, "")
    assert r.stderr == (f"error: cannot reach the control center at {ep}: Unable to connect to "
                        f"any of [Single({ep})]. Timeout! (is `esair std run` listening there?)\n")


@pytest.mark.parametrize("text, shown", [
    ("Unable to connect to any of [Single(tcp/127.0.0.1:9)]. Timeout! at "
     "/root/.cargo/git/checkouts/zenoh-9c599d5ef3e0480e/cc83980/zenoh/src/net/runtime/"
     "orchestrator.rs:388.", "Unable to connect to any of [Single(tcp/127.0.0.1:9)]. Timeout!"),
    ("Address already in use (os error 98) at zenoh-link-tcp/src/unicast.rs:12",
     "Address already in use (os error 98)"),
    ("no place given", "no place given"),
    ("what is at stake.rs", "what is at stake.rs"),      # not a source place: kept
])
def test_the_place_in_zenohs_source_is_cut(text, shown):
    assert zenoh_message(RuntimeError(text)) == shown
