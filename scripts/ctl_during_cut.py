"""Reproducer (issue 19.7): how fast the control center answers a control request made
on its own computer while a remote agent's link is cut. Two network namespaces
(esair_std/netsim.py; root needed): a control center (process mode) and a remote
agent commanding a local actuator (and, with --stream, a remote 200 Hz sensor read by
a local behavior). The link is cut, and from the control center's computer one client
session asks ``ctl/ping`` then ``ctl/ls`` every 50 ms for the next SECONDS: each
answer's time, after the cut, is printed with the time it took. Then the same with the
link up, as the baseline. With --puts RATE, an operator's puts to the remote behavior
(timeout 2 s each, RATE a second, none waiting for another) go on meanwhile: during the
cut each one holds a worker of the control endpoint until its timeout (issue 37 item 5:
``ls`` must not wait behind them).

Run: sudo python scripts/ctl_during_cut.py [--seconds 5] [--stream] [--puts 20]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from esair_std import netsim as netns
from bench.toolkit.netstd import Center, agent, env

LAB = """
robot: lab
mode: process
endpoint: ENDPOINT
security: {lease_ms: 1500}
resources:
  arm:   {class: "bench.toolkit.netcomps:Wheel", allow: {pusher: command}}
behaviors:
  idle:  {class: "bench.toolkit.netcomps:Idle"}
"""

ASKER = r"""
import json, sys, time
from esair_std.transport.bus import Bus
bus = Bus(connect=[sys.argv[1]], options={"mode": "client", "listen/endpoints": []})
print("ready", flush=True)
for line in sys.stdin:
    verb, t0 = line.split()[0], time.monotonic()
    if verb == "new":              # a session opened anew for one ls, as the CLI does
        b = Bus(connect=[sys.argv[1]], options={})
        r = b.request("esair/lab/ctl/ls", {}, 10.0)
        b.close()
    else:
        r = bus.request(f"esair/lab/ctl/{verb}", {}, 10.0)
    print(json.dumps([verb, time.monotonic(), time.monotonic() - t0, r is not None]), flush=True)
"""


PUTTER = r"""
import sys, threading, time
from esair_std.transport.bus import Bus
bus = Bus(connect=[sys.argv[1]], options={"mode": "client", "listen/endpoints": []})
every = 1.0 / float(sys.argv[2])
def put():
    bus.request("esair/lab/ctl/put", {"to": "pusher", "data": 1, "timeout": 2.0}, 5.0)
print("ready", flush=True)
while True:
    threading.Thread(target=put, daemon=True).start()
    time.sleep(every)
"""


def probe(center: Center, seconds: float, cut, verbs=("ping", "ls"), puts: float = 0) -> list:
    e = env()
    putter = None
    if puts:
        putter = center.host.popen(sys.executable, "-c", PUTTER, center.endpoint, str(puts),
                                   stdout=subprocess.PIPE, text=True, env=e)
        assert putter.stdout.readline().strip() == "ready"
    e.pop("ZENOH_RUNTIME", None)      # the asker: Zenoh's defaults
    asker = center.host.popen(sys.executable, "-c", ASKER, center.endpoint, stdin=subprocess.PIPE,
                              stdout=subprocess.PIPE, text=True, env=e)
    assert asker.stdout.readline().strip() == "ready"
    for verb in ("ping", "ls") * 3:                        # warm: routes known
        asker.stdin.write(verb + "\n")
        asker.stdin.flush()
        asker.stdout.readline()
    t_cut = time.monotonic()
    cut()
    out = []
    while time.monotonic() - t_cut < seconds:
        for verb in verbs:
            asker.stdin.write(verb + "\n")
            asker.stdin.flush()
            v, t_end, took, ok = json.loads(asker.stdout.readline())
            out.append((t_end - took - t_cut, v, took, ok))
        time.sleep(0.05)
    asker.stdin.close()
    asker.wait(10)
    if putter is not None:
        putter.kill()
        putter.wait(10)
    return out


def show(label: str, got: list, slow: float = 0.2) -> None:
    took = [t for _, _, t, _ in got]
    print(f"{label}: {len(got)} requests, median {statistics.median(took) * 1e3:.0f} ms, "
          f"max {max(took) * 1e3:.0f} ms, unanswered {sum(not ok for *_, ok in got)}")
    for at, verb, t, ok in got:
        if t > slow or not ok:
            print(f"   asked {at:5.2f} s after the cut: {verb:4s} took {t * 1e3:6.0f} ms"
                  f"{'' if ok else ' (no answer)'}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=float, default=5.0)
    ap.add_argument("--stream", action="store_true", help="a remote 200 Hz sensor too")
    ap.add_argument("--puts", type=float, default=0.0,
                    help="operator puts a second to the remote behavior meanwhile")
    ap.add_argument("--only-open", action="store_true",
                    help="the open session's rows only (not a new session per ls)")
    ap.add_argument("--rx", type=int, default=None,
                    help="the control center's Zenoh routing threads (default: the "
                         "runtime's 16; Zenoh's own default is 2)")
    args = ap.parse_args()
    if args.rx is not None:           # the runtime keeps a ZENOH_RUNTIME it is given
        os.environ["ZENOH_RUNTIME"] = f"(rx: (worker_threads: {args.rx}))"
    why = netns.unavailable()
    if why:
        raise SystemExit(f"scripts/ctl_during_cut.py: {why}")
    with tempfile.TemporaryDirectory() as tmp, netns.Net(2) as net:
        center = Center(net[0], Path(tmp), LAB)
        agent(net[1], center.endpoint, "pusher", "bench.toolkit.netcomps:Pusher",
              "--uses", "arm=command")
        if args.stream:
            agent(net[1], center.endpoint, "ticks", "bench.toolkit.netcomps:Counter",
                  "--allow", "watch2=read", "-o", "rate=200")
            netns.wait_for(lambda: center.state("ticks") == "ready", 60, what="ticks")
            center.ctl("add", "watch2", "bench.toolkit.netcomps:Watch", "--uses", "ticks=read")
        netns.wait_for(lambda: center.state("pusher") == "running", 60, what="pusher")
        show("link up (baseline)", probe(center, args.seconds, lambda: None, puts=args.puts))
        show("link cut", probe(center, args.seconds, lambda: net[1].link(up=False),
                               puts=args.puts))
        net[1].link(up=True)
        netns.wait_for(lambda: center.state("pusher") == "running", 60, what="pusher back")
        time.sleep(2)
        if args.only_open:
            show("link healed", probe(center, args.seconds, lambda: None, puts=args.puts))
            center.run.proc.terminate()
            center.run.wait_exit(30)
            return
        show("a new session (peer, as esair std ls) for each ls, link up (baseline)",
             probe(center, args.seconds, lambda: None, ("new",)))
        show("a new session (peer, as esair std ls) for each ls, link cut",
             probe(center, args.seconds, lambda: net[1].link(up=False), ("new",)))
        center.run.proc.terminate()
        center.run.wait_exit(30)


if __name__ == "__main__":
    main()
