"""ESAIR STD across computers: figures between two network namespaces (issue 12 item 4).

Host 0 (10.77.0.1) runs the control center, host 1 (10.77.0.2) the remote side; they
are joined by one veth pair (esair_std/netsim.py; root needed). Side by side in one run:

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
nothing. Parts 2-5 need the STD runtime's process mode (esair_std.hosts.agent_process).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench.toolkit.netstd import Center, Proc  # noqa: E402
from bench.toolkit.zpeer import Peer  # noqa: E402
from esair_std import netsim as netns  # noqa: E402
from esair_std.transport.tls_certs import make_certs  # noqa: E402
from esair_std.transport.security_config import Security, SecuritySpec, session_inserts  # noqa: E402


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


BENCH = """
robot: lab
mode: process
endpoint: ENDPOINT
SECURITY
resources:
  arm: {class: "bench.toolkit.netcomps:Wheel", allow: {putbench: command}}
behaviors:
  sink: {class: "bench.toolkit.netcomps:Sink"}
"""
TLS_SECTION = """security:
  ca: pki/ca.pem
  cert: pki/server.pem
  key: pki/server.key
  agents: {putbench: {cn: putbench}}"""


def remote_agent(host, endpoint: str, name: str, class_path: str, kind: str, **kw) -> Proc:
    args = dict(endpoint=endpoint, name=name, class_path=class_path, kind=kind, robot="lab",
                hostname="bench-pc", **kw)
    return Proc(host, [sys.executable, "-m", "esair_std.remote.remote_agent", json.dumps(args)])


def remote_put(net, base: Path, n: int, tls: bool, round_: int = 0) -> dict:
    """Remote put round trips (agent in host 1 -> BS in host 0 -> local behavior), the
    remote agent's join and one registration."""
    folder = base / f"{'tls' if tls else 'tcp'}{round_}"
    folder.mkdir()
    sec = None
    if tls:
        make_certs(folder / "pki", clients=["putbench"], hosts=[net[0].addr])
        d = folder / "pki"
        # what `esair std agent --ca --cert --key` hands the lean agent process
        sec = SecuritySpec(ca=d / "ca.pem", cert=d / "putbench.pem",
                           key=d / "putbench.key").model_dump(mode="json")
    dep = BENCH.replace("SECURITY", TLS_SECTION if tls else "")
    center = Center(net[0], folder, dep, tls)
    t0 = time.monotonic()
    agent = remote_agent(net[1], center.endpoint, "putbench", "bench.toolkit.netcomps:PutBench", "behavior",
                         uses={"arm": "command"}, options={"n": n, "actuator": "arm"}, sec=sec)
    line = agent.wait_line("joined robot", 60)
    start_s = time.monotonic() - t0              # interpreter, imports, session, join
    join_ms = float(line.rsplit(" in ", 1)[1].split()[0])
    def result():                # busy while its run() goes on: no data until it ends
        out = center.ctl("get", "putbench", "--timeout", "2", check=False,
                         endpoint=center.local if tls else None)
        return None if out.startswith("error") else json.loads(out)
    got = netns.wait_for(result, 60 + n * 0.05, interval=0.5, what="the put bench")
    center.run.proc.terminate()
    center.run.wait_exit(30)
    agent.proc.kill()
    return {"times": got["times"], "failed": got["failed"], "join_ms": join_ms,
            "start_s": start_s,
            "register_ms": got["register_s"] * 1e3}


STREAM = """
robot: lab
mode: process
endpoint: ENDPOINT
behaviors:
  idle: {class: "bench.toolkit.netcomps:Idle"}
"""


def stream(net, base: Path, seconds: float, down: float) -> dict:
    """A remote sensor at 1 kHz to a local behavior: loss with the link up; then the link
    down for ``down`` s and up: time to the first sample delivered again."""
    folder = base / "stream"
    center = Center(net[0], folder, STREAM)
    remote_agent(net[1], center.endpoint, "ticks", "bench.toolkit.netcomps:Counter", "resource",
                 allow={"stats": "read"}, options={"rate": 1000})
    netns.wait_for(lambda: center.state("ticks") == "ready", 60, what="remote sensor")
    center.ctl("add", "stats", "bench.toolkit.netcomps:StreamStats", "--uses", "ticks=read")
    first = center.get("stats")
    t0 = time.monotonic()
    time.sleep(seconds)
    up = center.get("stats")
    elapsed = time.monotonic() - t0
    net[1].link(up=False)
    time.sleep(down)
    t_up = time.time()
    net[1].link(up=True)
    after = netns.wait_for(lambda: (lambda s: s if len(s["holes"]) > len(up["holes"]) else None)(
        center.get("stats")), 30, what="samples after the partition")
    hole = after["holes"][len(up["holes"])]
    center.run.proc.terminate()
    center.run.wait_exit(30)
    span = up["last"] - (first["last"] or up["first"])
    got = up["count"] - first["count"]
    return {"expected": span, "received": got, "holes_up": up["holes"][len(first["holes"]):],
            "overwritten": up["overwritten"], "restore_s": hole[2] - t_up,
            "lost_in_partition": hole[1] - hole[0] - 1, "rate": span / elapsed}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=2000, help="round trips per figure")
    ap.add_argument("--seconds", type=float, default=5.0, help="1 kHz stream, link up")
    ap.add_argument("--down", type=float, default=3.0, help="partition length (s)")
    ap.add_argument("--repeat", type=int, default=3, help="rounds of raw/put figures")
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
        rounds = []              # raw and remote put interleaved: the machine is shared
        for r in range(args.repeat):
            f = {"raw_tcp": raw_get(net, args.n, None, None, f"tcp/{net[0].addr}:7447", base),
                 "put_tcp": remote_put(net, base, args.n, False, r),
                 "raw_tls": raw_get(net, args.n, tls_center, tls_agent,
                                    f"tls/{net[0].addr}:7448", base),
                 "put_tls": remote_put(net, base, args.n, True, r)}
            rounds.append(f)
        print("1-2. raw zenoh query/reply vs remote put (agent -> BS -> local behavior), "
              "same veth link")
        for r, f in enumerate(rounds):
            print(f"   round {r + 1}: raw tcp {fmt(f['raw_tcp'])}")
            print(f"            put tcp {fmt(f['put_tcp']['times'])}  "
                  f"failed {f['put_tcp']['failed']}")
            print(f"            raw tls {fmt(f['raw_tls'])}")
            print(f"            put tls {fmt(f['put_tls']['times'])}  "
                  f"failed {f['put_tls']['failed']}")

        def med(fn):
            return statistics.median(fn(f) for f in rounds)
        for q, name in ((0.5, "p50"), (0.99, "p99")):
            ratio = med(lambda f, q=q: pct(f["put_tcp"]["times"], q) / pct(f["raw_tcp"], q))
            tls_raw = med(lambda f, q=q: pct(f["raw_tls"], q) / pct(f["raw_tcp"], q))
            tls_put = med(lambda f, q=q: pct(f["put_tls"]["times"], q) /
                          pct(f["put_tcp"]["times"], q))
            print(f"   {name} (median of {len(rounds)} rounds): put/raw {ratio:.2f}x "
                  f"(goal <= 2.5x); TLS cost: raw {tls_raw:.2f}x, put {tls_put:.2f}x")
        figures = rounds[-1]
        st = stream(net, base, args.seconds, args.down)
        print(f"3. remote sensor at 1 kHz ({st['rate']:.0f} samples/s measured), link up "
              f"{args.seconds:g} s: {st['expected'] - st['received']} lost of "
              f"{st['expected']} (holes {st['holes_up']}, overwritten {st['overwritten']})"
              "   (goal 0)")
        print(f"4. link down {args.down:g} s, up: first sample again after "
              f"{st['restore_s'] * 1e3:.0f} ms (goal <= 2000 ms); "
              f"{st['lost_in_partition']} samples lost, shown by the sequence numbers")
        for label in ("tcp", "tls"):
            r = figures[f"put_{label}"]
            print(f"5. remote agent ({label}): join + hello {r['join_ms']:.1f} ms, one "
                  f"registration (command) {r['register_ms']:.1f} ms   (goal <= 300 ms); "
                  f"from process start {r['start_s']:.2f} s (Python, imports, session)")


if __name__ == "__main__":
    main()
