"""Components of bench/std_goals.py (imported by the runtime and by agent processes)."""

from __future__ import annotations

import glob
import os
import time

from esair_std import Behavior, Sensor


def _pcts(xs: list[float]) -> dict:
    xs = sorted(xs)
    if not xs:
        return {"n": 0}
    return {"n": len(xs), "p50": xs[len(xs) // 2], "p99": xs[min(len(xs) - 1, int(len(xs) * 0.99))],
            "max": xs[-1]}


def cpu_seconds(pid: int) -> float:
    """CPU time of every thread of process ``pid`` so far (schedstat's nanoseconds: finer
    than the clock ticks of /proc/PID/stat)."""
    total = 0
    for f in glob.glob(f"/proc/{pid}/task/*/schedstat"):
        try:
            with open(f) as fh:
                total += int(fh.read().split()[0])
        except (OSError, ValueError):
            pass                                    # a thread ended meanwhile
    return total / 1e9


class Ticker(Sensor):
    """Reports its own count at ``rate_hz``."""

    def open(self):
        self.n = 0

    def read(self):
        self.n += 1
        return self.n


class Echo(Behavior):
    def start(self):
        self.got = 0

    def receive(self, sender, data):
        self.got += 1

    def provide(self, requester):
        if requester == "pinger":          # where it runs: the pinger reads its CPU time
            return {"got": self.got, "pid": os.getpid()}
        return self.got


class Pinger(Behavior):
    """run(): ``n`` puts and ``n`` gets to 'echo', timed (seconds); provide() the figures.
    ``raw`` (process mode): a key the runtime's process answers by a bare Zenoh queryable;
    ``n`` raw ``get``s of that key from this agent's own session come first, timed alike:
    the reference taken between the same two processes, in the same run (before the
    puts: a get right after a put would carry the delivery's work in the other
    processes). ``runtime_pid`` (process mode): the CPU time per put and per raw get of
    the three processes (this one, the runtime's, the echo's) is measured too."""

    def _raw(self):
        key = self.options.get("raw")
        bus = getattr(self._esair.port, "bus", None)
        if not key or bus is None:
            return None
        payload = b'{"i":0}'

        def get():
            return any(r.ok is not None for r in bus.session.get(key, payload=payload,
                                                                 timeout=1.0))
        end = time.monotonic() + 30
        while not get() and time.monotonic() < end:     # until the bench's queryable is up
            time.sleep(0.01)
        return get

    def _pids(self):
        rt = self.options.get("runtime_pid")
        echo = self.get("echo", timeout=5.0) if rt else None
        if not isinstance(echo, dict):
            return {}
        return {"sender": os.getpid(), "runtime": int(rt), "target": echo["pid"]}

    def run(self):
        n = int(self.options.get("n", 2000))
        raw = self._raw()
        pids = self._pids()
        cpu = {}

        def cpu_now():
            return {k: cpu_seconds(p) for k, p in pids.items()}
        puts, gets, raws, failed = [], [], [], 0
        c0 = cpu_now()
        for _ in range(n if raw is not None else 0):
            t = time.perf_counter()
            failed += not raw()
            raws.append(time.perf_counter() - t)
        c1 = cpu_now()
        for i in range(n):
            t = time.perf_counter()
            ok = self.put("echo", {"i": i}, timeout=1.0)
            puts.append(time.perf_counter() - t)
            failed += not ok
        c2 = cpu_now()
        if pids and n:                  # seconds of CPU per call, each process
            cpu = {"raw": {k: (c1[k] - c0[k]) / n for k in pids},
                   "put": {k: (c2[k] - c1[k]) / n for k in pids}}
        for _ in range(n):
            t = time.perf_counter()
            v = self.get("echo", timeout=1.0)
            gets.append(time.perf_counter() - t)
            failed += v is None
        self.result = {"put": _pcts(puts), "get": _pcts(gets), "raw": _pcts(raws),
                       "failed": failed, "cpu": cpu}

    def provide(self, requester):
        return getattr(self, "result", None)


class Latency(Behavior):
    """Attaches to options['sensor']; polls every ``period`` and keeps sample ages
    (arrival seen in step - sample.t), every seq seen, and when the first came."""

    period = 0.001

    def start(self):
        self.h = self.attach_sensor(self.options.get("sensor", "tick"),
                                    keep=int(self.options.get("keep", 4096)))
        self.ages = []
        self.seqs = []
        self.first = None
        self.slow = float(self.options.get("slow", 0))

    def step(self):
        if self.slow:
            time.sleep(self.slow)
        now = time.time()
        got = self.h.samples()
        if got and self.first is None:
            self.first = now
        for s in got:
            self.ages.append(now - s.t)
            self.seqs.append(s.seq)

    def provide(self, requester):
        s = self.seqs
        return {"ages": _pcts(self.ages[50:]), "n": len(s), "first_seq": s[0] if s else None,
                "last_seq": s[-1] if s else None,
                "gaps": sum(1 for a, b in zip(s, s[1:]) if b != a + 1),
                "overwritten": self.h.overwritten, "first_t": self.first, "pid": os.getpid()}


class Idle(Behavior):
    period = 0.1

    def step(self):
        pass


class Churn(Behavior):
    """Puts once to 'echo' in start() and takes puts: one add/remove cycle of
    bench/std_churn.py uses every per-name path of the runtime."""

    def start(self):
        self.got = 0
        self.put("echo", {"from": self.name}, timeout=1.0)

    def receive(self, sender, data):
        self.got += 1
