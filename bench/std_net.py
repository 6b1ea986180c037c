"""ESAIR STD across computers: figures between two network namespaces (issue 12 item 4).

Host 0 (10.77.0.1) runs the control center, host 1 (10.77.0.2) the remote side; they
are joined by one veth pair (tests/netns.py; root needed). Side by side in one run:

1. raw Zenoh query/reply across the link (a client in host 1 asks a queryable of the
   router in host 0): the baseline, over tcp and over tls with client certificates;
2. remote ``put`` (a behavior in host 1 puts to a behavior of the control center through
   the BS) p50/p99 and its ratio to (1) (goal <= 2.5x); the same with mTLS: TLS's cost;
3. a remote sensor streaming at 1 kHz to a local behavior: samples lost with the link up
   (goal 0, by sequence numbers);
4. the link taken down for 3 s and up again: time from link up to the first sample
   delivered again (goal <= 2 s), and the samples lost meanwhile (by sequence numbers);
5. registration time of a remote agent: from process start to its registration granted,
   and from session open to registration (goal <= 300 ms).

Run: sudo python bench/std_net.py [--n 2000]. Prints figures and ratios; asserts
nothing. Parts 2-5 need the STD runtime's process mode (esair_std.modes.agent).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

import netns  # noqa: E402
from zpeer import Peer  # noqa: E402

from esair_std.transport.certs import make_certs  # noqa: E402
from esair_std.transport.security import Security, session_inserts  # noqa: E402


def pct(values: list[float], q: float) -> float:
    values = sorted(values)
    return values[min(len(values) - 1, int(q * len(values)))]


def fmt(values: list[float]) -> str:
    return (f"p50 {pct(values, 0.5) * 1e6:7.0f} us  p99 {pct(values, 0.99) * 1e6:7.0f} us  "
            f"(n={len(values)})")


def raw_get(net, n: int, sec_center: Security | None, sec_agent: Security | None,
            endpoint: str, base: Path) -> list[float]:
    center = Peer(net[0], {"mode": "router", "scouting/multicast/enabled": False,
                           "listen/endpoints": [endpoint],
                           **session_inserts(sec_center, base, listen=True)})
    center.cmd("serve bench/q")
    agent = Peer(net[1], {"mode": "client", "scouting/multicast/enabled": False,
                          "connect/endpoints": [endpoint], "listen/endpoints": [],
                          **session_inserts(sec_agent, base, listen=False)})
    if agent.error:
        raise SystemExit(f"raw zenoh client could not connect: {agent.error}")
    agent.cmd("rtt bench/q 50", timeout=60)                  # warm up
    times = agent.cmd(f"rtt bench/q {n}", timeout=60 + n * 0.05)["rtt"]
    agent.close()
    center.close()
    lost = sum(t is None for t in times)
    if lost:
        print(f"  ({lost} raw queries got no reply)")
    return [t for t in times if t is not None]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=2000, help="round trips per figure")
    args = ap.parse_args()
    why = netns.unavailable()
    if why:
        raise SystemExit(f"bench/std_net.py: {why}")
    figures = {}
    with tempfile.TemporaryDirectory() as tmp, netns.Net(2) as net:
        base = Path(tmp)
        make_certs(base, clients=["agent"], hosts=[net[0].addr])
        tls_center = Security(ca="ca.pem", cert="server.pem", key="server.key")
        tls_agent = Security(ca="ca.pem", cert="agent.pem", key="agent.key")
        figures["raw_tcp"] = raw_get(net, args.n, None, None, f"tcp/{net[0].addr}:7447", base)
        figures["raw_tls"] = raw_get(net, args.n, tls_center, tls_agent,
                                     f"tls/{net[0].addr}:7448", base)
        print("1. raw zenoh query/reply across the veth link")
        print(f"   tcp           {fmt(figures['raw_tcp'])}")
        print(f"   tls (mTLS)    {fmt(figures['raw_tls'])}   "
              f"TLS/tcp p50 {statistics.median(figures['raw_tls']) / statistics.median(figures['raw_tcp']):.2f}x")
        try:
            import runtime_bench  # noqa: F401  (parts 2-5, once process mode exists)
        except ImportError:
            print("2-5. remote put / stream / partition / registration: need the STD "
                  "runtime's process mode (not on this tree)")
            return
        runtime_bench.run(net, base, args, figures)


if __name__ == "__main__":
    main()
