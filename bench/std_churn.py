"""ESAIR STD benchmark: differently named behaviors added and removed, 2 000 times, in
process mode; the runtime's RSS and its per-name tables along the way (issue 19 item 7).

Each cycle adds ``c<i>`` (bench/std_comps.py Churn: it puts to 'echo' in start()),
puts to it from the operator, and removes it: every path that keeps something per name
(the BS's deliver and offer publishers, the answers to a sender's puts) is used.
RSS is read from /proc/self/status; the baseline is the RSS after the first
``--warm`` cycles (caches, Zenoh's pools), the figure the ratio of the last to it.

Run: python bench/std_churn.py [--cycles N] [--warm N]. Prints; asserts nothing.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

BENCH = Path(__file__).resolve().parent
sys.path[:0] = [str(BENCH.parent), str(BENCH)]

from esair_std import Runtime  # noqa: E402
from toolkit import free_endpoint  # noqa: E402


def rss_mb() -> float:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return 0.0


def tables(rt: Runtime) -> tuple[int, int, int, int]:
    return (len(rt.mode._deliver_pubs), len(rt.mode.offers._pubs), len(rt.server.puts._pubs),
            len(rt.server.bus._pub_of))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--cycles", type=int, default=2000)
    ap.add_argument("--warm", type=int, default=200)
    ap.add_argument("--every", type=int, default=250)
    a = ap.parse_args()
    dep = {"robot": "churn", "behaviors": {"echo": {"class": "std_comps:Echo"}}}
    with Runtime(dep, mode="process", endpoint=free_endpoint()) as rt:
        t0 = time.monotonic()
        base = None
        print(f"  {'cycles':>6} {'RSS MB':>8} {'x base':>7}  tables (deliver, offer, answer, "
              f"publishers)  s", flush=True)
        for i in range(1, a.cycles + 1):
            name = f"c{i}"
            rt.add(name, "std_comps:Churn")
            rt.put(name, {"i": i}, timeout=1.0)
            rt.remove(name)
            if i == a.warm:
                base = rss_mb()
            if i % a.every == 0 or i == a.cycles:
                r = rss_mb()
                ratio = f"{r / base:.3f}" if base else "-"
                print(f"  {i:>6} {r:>8.1f} {ratio:>7}  {tables(rt)}  {time.monotonic() - t0:.0f}",
                      flush=True)
        print(f"echo received {rt.get('echo')} puts", flush=True)


if __name__ == "__main__":
    main()
