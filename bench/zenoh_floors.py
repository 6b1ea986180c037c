"""The floors of process mode's paths with no ESAIR code, between processes opened as
STD opens its sessions (transport/session.py): a raw zenoh get; the same through a
relay; samples relayed A -> R -> A and A -> R -> E -> R -> A; a put's floor (A -> R -> A
with JSON, R also delivering to E, whose callback hands it to a thread); the put answered
by its target instead (A -> E -> A, E handing it to a thread, with and without telling R
after); the CPU a subscriber's callback costs with Zenoh's thread state made anew for
each call and kept (transport/threadstate.py); one-way samples at a sensor's rate. Used
by bench/std_goals.py (and bench/papaman_std.py) beside STD's
figures; run alone: python bench/zenoh_floors.py [--n 500]. Prints figures; asserts
nothing.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

BENCH = Path(__file__).resolve().parent
ROOT = BENCH.parent
if str(BENCH) not in sys.path:
    sys.path.insert(0, str(BENCH))

from toolkit import free_endpoint  # noqa: E402


def pct(xs: list[float], p: float) -> float:
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(len(xs) * p))]


def wait(fn, timeout: float = 60.0):
    end = time.monotonic() + timeout
    while not (v := fn()):
        if time.monotonic() > end:
            raise TimeoutError("the floor's echo never answered")
        time.sleep(0.01)
    return v


ZENOH_SERVER = """
import sys, time
from esair_std.transport.session import open_session
s = open_session(listen=[sys.argv[1]])
q = s.declare_queryable("bench/echo",
                        lambda query: (query.reply(query.key_expr, query.payload), query.drop()))
print("ready", flush=True)
sys.stdin.read()
import os
os._exit(0)
"""


ZENOH_RELAY = """
import queue, sys, threading
from esair_std.transport.session import open_session
s = open_session(listen=[sys.argv[1]], connect=[sys.argv[2]])
q = queue.Queue()
def work():
    while True:
        query = q.get()
        replies = list(s.get("bench/echo", payload=query.payload.to_bytes(), timeout=1.0))
        query.reply(query.key_expr, replies[0].ok.payload.to_bytes())
        query.drop()
threading.Thread(target=work, daemon=True).start()
r = s.declare_queryable("bench/relay", q.put)
print("ready", flush=True)
sys.stdin.read()
import os
os._exit(0)
"""


def timed_gets(endpoint: str, key: str, body: dict, n: int) -> float:
    """p50 of ``n`` plain ``session.get`` round trips to ``key`` (a session of its own)."""
    from esair_std.transport.session import open_session
    s = open_session(connect=[endpoint])
    payload = json.dumps(body).encode()
    wait(lambda: list(s.get(key, payload=payload, timeout=1.0)))
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        list(s.get(key, payload=payload, timeout=1.0))
        times.append(time.perf_counter() - t0)
    s.close()
    return pct(times, 0.5)


SAMPLE_HOP = """
import sys, zenoh
from esair_std.transport.session import open_session
s = open_session(listen=[sys.argv[1]], connect=sys.argv[4:])
pub = s.declare_publisher(sys.argv[3], congestion_control=zenoh.CongestionControl.DROP,
                          express=True)
s.declare_subscriber(sys.argv[2], zenoh.handlers.Callback(
    lambda smp: pub.put(smp.payload.to_bytes()), indirect=False))
print("ready", flush=True)
sys.stdin.read()
import os
os._exit(0)
"""


SAMPLE_DELIVER = """
import json, queue, sys, threading, zenoh
from esair_std.transport.session import open_session
s = open_session(listen=[sys.argv[1]], connect=sys.argv[2:])
if len(sys.argv) > 2:       # the relay: answers the sender, then delivers to the target
    ans = s.declare_publisher("f/answer", congestion_control=zenoh.CongestionControl.BLOCK,
                              express=True)
    dlv = s.declare_publisher("f/deliver", congestion_control=zenoh.CongestionControl.BLOCK,
                              express=True)
    def relay(smp):
        body = json.loads(smp.payload.to_bytes())
        ans.put(json.dumps({"ok": {"delivered": True}, "id": body["id"]}).encode())
        dlv.put(json.dumps({"from": "pinger", "data": body["data"]}).encode())
    s.declare_subscriber("f/put", zenoh.handlers.Callback(relay, indirect=False))
else:                       # the target: each delivery to a thread of its own, woken
    box = queue.Queue(maxsize=64)
    def work():
        while True:
            box.get()
    threading.Thread(target=work, daemon=True).start()
    s.declare_subscriber("f/deliver", zenoh.handlers.Callback(
        lambda smp: box.put_nowait(json.loads(smp.payload.to_bytes())), indirect=False))
print("ready", flush=True)
sys.stdin.read()
import os
os._exit(0)
"""


def zenoh_put_floor(n: int) -> float:
    """A put into reserved room with no ESAIR code: A -> R (JSON decoded), R answers A
    and delivers to E (whose callback hands it to a thread): what a put must do."""
    e_ep, r_ep = free_endpoint(), free_endpoint()
    return _puts(SAMPLE_DELIVER, ([e_ep], [r_ep, e_ep]), r_ep, n, {})


def _puts(script: str, argv: tuple[list[str], ...], to: str, n: int, extra: dict) -> float:
    """p50 of ``n`` puts from this process to the session at ``to``, each waiting for its
    answer, with a process of ``script`` started for each of ``argv`` (in order)."""
    import queue

    import zenoh

    from esair_std.transport.session import open_session
    procs = []
    try:
        for args in argv:
            procs.append(subprocess.Popen([sys.executable, "-c", script, *args],
                                          stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                          text=True, cwd=ROOT))
            procs[-1].stdout.readline()
        s = open_session(connect=[to])
        got: queue.SimpleQueue = queue.SimpleQueue()
        s.declare_subscriber("f/answer", zenoh.handlers.Callback(
            lambda smp: got.put(json.loads(smp.payload.to_bytes())), indirect=False))
        pub = s.declare_publisher("f/put", congestion_control=zenoh.CongestionControl.DROP,
                                  express=True)

        def one(i: int) -> bool:
            pub.put(json.dumps({"to": "echo", "data": {"i": i}, "timeout": 1.0, "id": i,
                                **extra}).encode())
            try:
                return bool(got.get(timeout=1.0))
            except queue.Empty:
                return False
        wait(lambda: one(0))
        times = []
        for i in range(n):
            t0 = time.perf_counter()
            if one(i):
                times.append(time.perf_counter() - t0)
        s.close()
        return pct(times, 0.5)
    finally:
        for p in procs:
            assert p.stdin is not None
            p.stdin.close()
            p.wait(5)


TARGET_ANSWERS = """
import json, queue, sys, threading, zenoh
from esair_std.transport.session import open_session
s = open_session(listen=[sys.argv[1]], connect=sys.argv[2:])
B = zenoh.CongestionControl.BLOCK
if len(sys.argv) > 2:       # the target: answers the sender, hands the data to a thread,
    ans = s.declare_publisher("f/answer", congestion_control=B, express=True)
    told = s.declare_publisher("f/told", congestion_control=B, express=True)
    box = queue.Queue(maxsize=64)
    def work():
        while True:
            box.get()
    threading.Thread(target=work, daemon=True).start()
    def take(smp):
        body = json.loads(smp.payload.to_bytes())
        ans.put(json.dumps({"ok": {"delivered": True}, "id": body["id"]}).encode())
        box.put_nowait(body)
        if body.get("tell"):  # then tells the runtime what it took
            told.put(json.dumps({"from": "pinger", "id": body["id"]}).encode())
    s.declare_subscriber("f/put", zenoh.handlers.Callback(take, indirect=False))
else:                       # the runtime, told after
    s.declare_subscriber("f/told", zenoh.handlers.Callback(
        lambda smp: json.loads(smp.payload.to_bytes()), indirect=False))
print("ready", flush=True)
sys.stdin.read()
import os
os._exit(0)
"""


def zenoh_target_answers(n: int, tell: bool) -> float:
    """A put answered by its target's process, as a raw get is (A -> E -> A, E handing
    the data to a thread), no ESAIR code; ``tell``: E then tells R what it took (a
    runtime that must know of every put, told after)."""
    r_ep, e_ep = free_endpoint(), free_endpoint()
    return _puts(TARGET_ANSWERS, ([r_ep], [e_ep, r_ep]), e_ep, n, {"tell": tell})


CALLBACK_SINK = """
import sys, zenoh
from esair_std.transport import threadstate
from esair_std.transport.session import open_session
keep = sys.argv[2] == "keep"
s = open_session(listen=[sys.argv[1]])
def cb(smp):
    if keep:
        threadstate.keep()
    smp.payload.to_bytes()
s.declare_subscriber("f/cb", zenoh.handlers.Callback(cb, indirect=False))
print("ready", flush=True)
sys.stdin.read()
import os
os._exit(0)
"""


def _cpu_ns(pid: int) -> int:
    """CPU time of every thread of ``pid`` so far (schedstat: nanoseconds)."""
    import glob
    total = 0
    for f in glob.glob(f"/proc/{pid}/task/*/schedstat"):
        try:
            total += int(Path(f).read_text().split()[0])
        except (OSError, ValueError):
            pass                                    # a thread ended meanwhile
    return total


def callback_cpu(n: int, keep: bool) -> float:
    """CPU seconds a subscriber's process spends per sample (one every 0.5 ms, a
    callback on Zenoh's thread that reads it), with Zenoh's thread state made anew for
    each callback, or kept (``keep``: transport/threadstate.py)."""
    import zenoh

    from esair_std.transport.session import open_session
    ep = free_endpoint()
    sink = subprocess.Popen([sys.executable, "-c", CALLBACK_SINK, ep,
                             "keep" if keep else "anew"], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True, cwd=ROOT)
    assert sink.stdin is not None and sink.stdout is not None
    try:
        sink.stdout.readline()
        s = open_session(connect=[ep])
        pub = s.declare_publisher("f/cb", congestion_control=zenoh.CongestionControl.BLOCK,
                                  express=True)
        payload = json.dumps({"from": "pinger", "data": {"i": 0}}).encode()
        for _ in range(200):                        # the link up, the threads started
            pub.put(payload)
            time.sleep(0.0005)
        before = _cpu_ns(sink.pid)
        for _ in range(n):
            pub.put(payload)
            time.sleep(0.0005)
        time.sleep(0.1)
        spent = _cpu_ns(sink.pid) - before
        s.close()
        return spent / n / 1e9
    finally:
        sink.stdin.close()
        sink.wait(5)


def zenoh_sample_relay_round_trip(n: int, hops: int = 4) -> float:
    """A mediated put's floor through samples, no ESAIR code: A -> R -> E -> R -> A,
    four one-way samples (what transport/calls.py does, with the handling left out);
    ``hops=2``: A -> R -> A, a put into room the target reserved (R answers at once, its
    delivery to E off the sender's path)."""
    import queue

    import zenoh

    from esair_std.transport.session import open_session
    e_ep, r_ep = free_endpoint(), free_endpoint()
    procs = []
    chain = ([e_ep, "f/offer", "f/result"], [r_ep, "f/put", "f/offer", e_ep],
             [free_endpoint(), "f/result", "f/answer", r_ep])
    if hops == 2:
        chain = ([r_ep, "f/put", "f/answer"],)
    try:
        for args in chain:
            procs.append(subprocess.Popen([sys.executable, "-c", SAMPLE_HOP, *args],
                                          stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                          text=True, cwd=ROOT))
            procs[-1].stdout.readline()
        s = open_session(connect=[r_ep])
        got: queue.SimpleQueue = queue.SimpleQueue()
        s.declare_subscriber("f/answer", zenoh.handlers.Callback(
            lambda smp: got.put(1), indirect=False))
        pub = s.declare_publisher("f/put", congestion_control=zenoh.CongestionControl.DROP,
                                  express=True)
        payload = json.dumps({"id": 1, "to": "echo", "data": {"i": 0}}).encode()

        def one() -> bool:
            pub.put(payload)
            try:
                return bool(got.get(timeout=1.0))
            except queue.Empty:
                return False
        wait(one)
        times = []
        for _ in range(n):
            t0 = time.perf_counter()
            if one():
                times.append(time.perf_counter() - t0)
        s.close()
        return pct(times, 0.5)
    finally:
        for p in procs:
            p.stdin.close()
            p.wait(5)


def zenoh_relay_round_trip(n: int) -> float:
    """The mediation's floor by queries: A gets from R, whose worker thread gets from E
    first."""
    e_ep, r_ep = free_endpoint(), free_endpoint()
    echo = subprocess.Popen([sys.executable, "-c", ZENOH_SERVER, e_ep], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True, cwd=ROOT)
    relay = None
    try:
        echo.stdout.readline()
        relay = subprocess.Popen([sys.executable, "-c", ZENOH_RELAY, r_ep, e_ep],
                                 stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                                 cwd=ROOT)
        relay.stdout.readline()
        return timed_gets(r_ep, "bench/relay",
                          {"from": "pinger", "to": "echo", "data": {"i": 0}}, n)
    finally:
        for p in (relay, echo):
            if p is not None:
                p.stdin.close()
                p.wait(5)


def zenoh_get_round_trip(n: int) -> float:
    ep = free_endpoint()
    srv = subprocess.Popen([sys.executable, "-c", ZENOH_SERVER, ep], stdin=subprocess.PIPE,
                           stdout=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        srv.stdout.readline()
        return timed_gets(ep, "bench/echo", {"op": "offer", "from": "pinger",
                                             "data": {"i": 0}}, n)
    finally:
        srv.stdin.close()
        srv.wait(5)


# ---- STD
SAMPLE_SINK = """
import json, sys, time, zenoh
from esair_std.transport.session import open_session
s = open_session(listen=[sys.argv[1]])
ages = []
s.declare_subscriber("bench/oneway", zenoh.handlers.Callback(
    lambda smp: ages.append(time.time() - json.loads(smp.payload.to_bytes())["t"]),
    indirect=False))
print("ready", flush=True)
sys.stdin.read()
print(json.dumps(ages), flush=True)
"""


def raw_sample_ages(rate: float, seconds: float) -> list[float]:
    """One-way ages of raw zenoh samples at ``rate`` between two processes, published as
    a sensor's host publishes (BLOCK, a stamped JSON value): process mode's sensor ->
    behavior path with no ESAIR code, taken on its receiving callback."""
    import zenoh

    from esair_std.transport.session import open_session
    ep = free_endpoint()
    sink = subprocess.Popen([sys.executable, "-c", SAMPLE_SINK, ep], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True, cwd=ROOT)
    assert sink.stdin is not None and sink.stdout is not None
    sink.stdout.readline()
    s = open_session(connect=[ep])
    pub = s.declare_publisher("bench/oneway", congestion_control=zenoh.CongestionControl.BLOCK)
    time.sleep(0.5)
    nxt = time.monotonic()
    for i in range(int(rate * seconds)):
        pub.put(json.dumps({"v": i, "seq": i, "t": time.time()}).encode())
        nxt += 1 / rate
        time.sleep(max(0.0, nxt - time.monotonic()))
    sink.stdin.close()
    ages = json.loads(sink.stdout.readline())
    sink.wait(10)
    s.close()
    return ages


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=500, help="round trips per figure")
    a = ap.parse_args()
    sys.path.insert(0, str(ROOT))
    print(f"zenoh floors ({os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}), p50:")
    z = zenoh_get_round_trip(a.n)
    print(f"  raw get                      {z*1e6:7.0f} us")
    for name, t in (("get through a relay", zenoh_relay_round_trip(a.n)),
                    ("samples A-R-A", zenoh_sample_relay_round_trip(a.n, hops=2)),
                    ("samples A-R-E-R-A", zenoh_sample_relay_round_trip(a.n)),
                    ("put floor A-R-A + R-E, JSON", zenoh_put_floor(a.n)),
                    ("target answers A-E-A", zenoh_target_answers(a.n, tell=False)),
                    ("the same, E tells R after", zenoh_target_answers(a.n, tell=True))):
        print(f"  {name:28s} {t*1e6:7.0f} us = {t/z:.2f}x the get")
    anew, kept = callback_cpu(3 * a.n, keep=False), callback_cpu(3 * a.n, keep=True)
    print(f"  callback CPU per sample, thread state made anew {anew*1e6:.0f} us, kept "
          f"{kept*1e6:.0f} us")
    ages = raw_sample_ages(50, 10.0)
    print(f"  one-way samples at 50 Hz     p50 {pct(ages, 0.5)*1e3:.2f} ms, "
          f"p99 {pct(ages, 0.99)*1e3:.2f} ms (n {len(ages)})")


if __name__ == "__main__":
    main()
