"""When a cut link makes a remote behavior `lost`, then `failed` (issue 19.8): between
two network namespaces (esair_std/netsim.py; root needed) a control center and a
remote agent (an idle behavior); the veth is cut and the center's output line
``NAME: remote agent lost`` (then ``NAME failed (remote agent unreachable ...)``) is
timed from the cut, then the link healed. Side by side in one run: the control center's
lease (``security.lease_ms``) and the agent's own session lease (2 s by default, set
here through the agent's security fields) varied one at a time: Zenoh drops a silent
session after the lease *that session* declared, so `lost` follows the agent's lease and
`failed` comes 3 of the center's leases after it.

Run: sudo python bench/std_net_lost.py [--rounds 3]. Prints figures; asserts nothing.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bench.toolkit.netstd import Center, Proc
from esair_std import netsim as netns

NO_TLS = dict(ca=None, cert=None, key=None, users=None, user=None, password_file=None,
              mtls=False, verify_name=False)

DEPLOYMENT = """
robot: lab
mode: process
endpoint: ENDPOINT
security: {{lease_ms: {lease}}}
behaviors:
  idle:  {{class: "bench.toolkit.netcomps:Idle"}}
"""


def _seen(proc, text: str, timeout: float) -> float:
    """When a line holding ``text`` was first seen (monotonic; 5 ms polls)."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if any(text in ln for ln in proc.lines):
            return time.monotonic()
        time.sleep(0.005)
    raise AssertionError(f"no {text!r} within {timeout} s")


def rounds(net, base: Path, lease_ms: int, agent_ms: int, n: int) -> list[tuple[float, float]]:
    center = Center(net[0], base / f"{lease_ms}-{agent_ms}", DEPLOYMENT.format(lease=lease_ms))
    kw = dict(endpoint=center.endpoint, name="far", class_path="bench.toolkit.netcomps:Idle",
              kind="behavior", hostname="far", sec={**NO_TLS, "lease_ms": agent_ms})
    far = Proc(net[1], [sys.executable, "-m", "esair_std.remote.remote_agent", json.dumps(kw)])
    out = []
    try:
        for _ in range(n):
            netns.wait_for(lambda: center.state("far") == "running", 60, what="far running")
            time.sleep(1.0)                      # keep-alives flowing again
            center.run.lines.clear()
            t0 = time.monotonic()
            net[1].link(up=False)
            lost = _seen(center.run, "far: remote agent lost", 30) - t0
            failed = _seen(center.run, "far failed (remote agent unreachable", 60) - t0
            net[1].link(up=True)
            out.append((lost, failed))
    finally:
        far.proc.terminate()
        center.run.proc.terminate()
        center.run.wait_exit(30)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()
    why = netns.unavailable()
    if why:
        raise SystemExit(f"bench/std_net_lost.py: {why}")
    with tempfile.TemporaryDirectory() as tmp, netns.Net(2) as net:
        for lease_ms, agent_ms in ((2000, 2000), (1500, 2000), (2000, 1000), (2000, 4000)):
            got = rounds(net, Path(tmp), lease_ms, agent_ms, args.rounds)
            lease, own = lease_ms / 1000, agent_ms / 1000
            lost = [a for a, _ in got]
            failed = [b for _, b in got]
            lm, fm = statistics.median(lost), statistics.median(failed)
            print(f"center lease {lease:g} s, agent lease {own:g} s: cut -> lost median "
                  f"{lm:.2f} s (min {min(lost):.2f}, max {max(lost):.2f}) = agent lease "
                  f"{lm - own:+.2f} s; cut -> failed median {fm:.2f} s = lost + 3 center "
                  f"leases {fm - lm - 3 * lease:+.2f} s  ({len(got)} cuts)")


if __name__ == "__main__":
    main()
