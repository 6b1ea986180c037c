"""The bare cost of process mode's command hop, without STD: one-way time from a sender's
``time.monotonic()`` to a worker thread in another process, through a Zenoh get (the
sessions opened as STD opens them, transport/session.py) whose queryable callback runs on
Zenoh's thread (``indirect=False``, as transport/bus.py) and hands the request to a worker
thread by a queue.Queue (as the resource host's command queue); the worker answers. And
thread mode's equivalent: a thread handing the same to a worker thread by a queue.Queue in
one process. ``time.monotonic()`` is CLOCK_MONOTONIC, one clock for every process.

Used by bench/papaman_std.py (figure 1: process mode's floor); run alone:
python bench/zenoh_hop.py [--n 200] [--every 0.0373]. Prints figures; asserts nothing.
"""

from __future__ import annotations

import argparse
import json
import queue
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
KEY = "bench/hop"

SERVER = r"""
import json, queue, sys, threading, time
import zenoh
from esair_std.transport.session import open_session

session = open_session(listen=[sys.argv[1]])
jobs = queue.Queue(maxsize=256)
rows = []

def work():
    while True:
        item = jobs.get()
        if item is None:
            return
        query, t_sent, t_cb = item
        rows.append((t_sent, t_cb, time.monotonic()))
        query.reply(query.key_expr, b"{}", express=%(express)s)
        query.drop()

def on_query(query):
    t_cb = time.monotonic()
    t_sent = json.loads(query.payload.to_bytes())["t"]
    jobs.put_nowait((query, t_sent, t_cb))

worker = threading.Thread(target=work, daemon=True)
worker.start()
q = session.declare_queryable("%(key)s", zenoh.handlers.Callback(on_query, indirect=False))
print("ready", flush=True)
sys.stdin.read()
jobs.put(None)
worker.join(2)
print(json.dumps(rows), flush=True)
q.undeclare()
session.close()
"""


def free_endpoint() -> str:
    import socket

    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return f"tcp/127.0.0.1:{sock.getsockname()[1]}"


def _pct(xs: list[float], q: float) -> float:
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(q * len(xs)))]


def _figures(rows: list[tuple[float, float, float]]) -> dict:
    """Per request (sent, on the receiver's callback, on its worker): ms p50/p99 of the
    hop (sent -> callback), the hand-off (callback -> worker) and both."""
    out = {}
    for name, a, b in (("hop", 0, 1), ("handoff", 1, 2), ("total", 0, 2)):
        xs = [(r[b] - r[a]) * 1e3 for r in rows]
        out[name] = (statistics.median(xs), _pct(xs, 0.99))
        out[name + "s"] = xs
    return out


def two_processes(n: int, every: float, express: bool = True) -> dict:
    """Process mode's hop: a get from this process to a queryable in another, handed to
    its worker thread (one request in flight, one every ``every`` s)."""
    from esair_std.transport.session import open_session

    ep = free_endpoint()
    srv = subprocess.Popen([sys.executable, "-c", SERVER % {"key": KEY, "express": express},
                            ep], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                           cwd=ROOT)
    try:
        assert srv.stdin is not None and srv.stdout is not None
        srv.stdout.readline()
        session = open_session(connect=[ep])
        try:
            for _ in range(50):                   # until the queryable is known
                if any(r.ok is not None for r in session.get(KEY, payload=b'{"t": 0}',
                                                             timeout=0.5)):
                    break
            for _ in range(n):
                t = time.monotonic()
                for _r in session.get(KEY, payload=json.dumps({"t": t}).encode(),
                                      timeout=2.0, express=express):
                    pass
                time.sleep(max(0.0, every - (time.monotonic() - t)))
        finally:
            session.close()
        srv.stdin.close()
        rows = json.loads(srv.stdout.readline())
    finally:
        srv.wait(10)
    return _figures([r for r in rows if r[0] > 0])


def one_process(n: int, every: float) -> dict:
    """Thread mode's hand-off: a thread puts the request on a queue.Queue, a worker takes
    it and answers through an Event (as the resource host and its sender in one
    process); ``hop`` is 0 here."""
    jobs: queue.Queue = queue.Queue(maxsize=256)
    rows: list[tuple[float, float, float]] = []

    def work() -> None:
        while True:
            item = jobs.get()
            if item is None:
                return
            t, done = item
            rows.append((t, t, time.monotonic()))
            done.set()

    worker = threading.Thread(target=work, daemon=True)
    worker.start()
    for _ in range(n):
        t = time.monotonic()
        done = threading.Event()
        jobs.put_nowait((t, done))
        done.wait(2.0)
        time.sleep(max(0.0, every - (time.monotonic() - t)))
    jobs.put(None)
    worker.join(2)
    return _figures(rows)


def main() -> None:
    sys.path.insert(0, str(ROOT))
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=200)
    ap.add_argument("--every", type=float, default=0.0373)
    args = ap.parse_args()
    for name, r in (("two processes (Zenoh get)", two_processes(args.n, args.every)),
                    ("one process (queue)", one_process(args.n, args.every))):
        print(f"{name:28s} n={r['n']}  " + ", ".join(
            f"{k} p50 {r[k][0]:.3f} / p99 {r[k][1]:.3f} ms" for k in ("hop", "handoff", "total")))


if __name__ == "__main__":
    main()
