"""ESAIR STD benchmark: idle CPU (issue 25 item 3), side by side in one run.

  process mode  a runtime with 10 idle behaviors (period 1 s), its agent processes
                included, vs 11 bare Zenoh sessions (one listening, ten connected to
                it, each its own process, doing nothing): goal <= 1.5x
  thread mode   a runtime with 10 idle behaviors (period 1 s), no control endpoint:
                goal <= 0.5 % of a core

CPU is user + system time from /proc/<pid>/stat of every process of the set, over a
window of --window seconds after --settle seconds; "% of a core" = CPU seconds per
wall second x 100. Run: python bench/std_idle_cpu.py [--window S] [--settle S]
[--before OTHER_CHECKOUT]. Prints the figures; asserts nothing.
"""

from __future__ import annotations

import argparse
import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

BENCH = Path(__file__).resolve().parent
ROOT = BENCH.parent
TICK = os.sysconf("SC_CLK_TCK")

RUNTIME = """
import sys, time, signal
sys.path[:0] = [{root!r}, {bench!r}]
from esair_std import Runtime
dep = {{"robot": "idle", "behaviors": {{f"b{{i}}": {{"class": "std_comps:Idle", "period": 1.0}}
                                     for i in range(10)}}}}
rt = Runtime(dep, mode={mode!r}, endpoint={ep!r}).start()
print("up", flush=True)
signal.sigwait([signal.SIGTERM])
rt.stop()
"""

SESSION = """
import json, signal, sys, zenoh
conf = zenoh.Config()
conf.insert_json5("scouting/multicast/enabled", "false")
conf.insert_json5(sys.argv[1], json.dumps([sys.argv[2]]))
if sys.argv[1] == "connect/endpoints":      # as an agent: it dials the runtime only
    conf.insert_json5("scouting/gossip/autoconnect", json.dumps({"peer": []}))
s = zenoh.open(conf)
print("up", flush=True)
signal.sigwait([signal.SIGTERM])
s.close()
"""


def free_endpoint() -> str:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return f"tcp/127.0.0.1:{s.getsockname()[1]}"


def family(pid: int) -> list[int]:
    """``pid`` and its descendants."""
    kids: dict[int, list[int]] = {}
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                with open(f"/proc/{d}/stat") as f:
                    ppid = int(f.read().rsplit(")", 1)[1].split()[1])
            except (OSError, ValueError, IndexError):
                continue
            kids.setdefault(ppid, []).append(int(d))
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        out.append(p)
        todo += kids.get(p, [])
    return out


def cpu_ticks(pids: list[int]) -> int:
    total = 0
    for p in pids:
        try:
            with open(f"/proc/{p}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
            total += int(fields[11]) + int(fields[12])      # utime, stime
        except (OSError, ValueError, IndexError):
            pass
    return total


def measure(pids: list[int], window: float) -> float:
    """% of one core used by ``pids`` over ``window`` seconds."""
    a, t0 = cpu_ticks(pids), time.monotonic()
    time.sleep(window)
    b, t1 = cpu_ticks(pids), time.monotonic()
    return 100.0 * (b - a) / TICK / (t1 - t0)


def started(cmd: list[str], root: Path = ROOT) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(root), str(BENCH)]))
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True, env=env)
    if p.stdout.readline().strip() != "up":
        raise SystemExit(f"{cmd[:3]} did not start")
    return p


def stopped(procs: list[subprocess.Popen]) -> None:
    for p in procs:
        p.terminate()
    for p in procs:
        try:
            p.wait(10)
        except subprocess.TimeoutExpired:
            p.kill()


def runtime(mode: str, window: float, settle: float, root: Path = ROOT) -> tuple[float, int]:
    code = RUNTIME.format(root=str(root), bench=str(BENCH), mode=mode, ep=free_endpoint())
    p = started([sys.executable, "-c", code], root)
    try:
        time.sleep(settle)
        pids = family(p.pid)
        return measure(pids, window), len(pids)
    finally:
        stopped([p])


def bare(window: float, settle: float) -> tuple[float, int]:
    ep = free_endpoint()
    procs = [started([sys.executable, "-c", SESSION, "listen/endpoints", ep])]
    try:
        procs += [started([sys.executable, "-c", SESSION, "connect/endpoints", ep])
                  for _ in range(10)]
        time.sleep(settle)
        return measure([p.pid for p in procs], window), len(procs)
    finally:
        stopped(procs)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--window", type=float, default=10.0)
    ap.add_argument("--settle", type=float, default=3.0)
    ap.add_argument("--before", type=Path, default=None,
                    help="another checkout (e.g. a worktree of main): its runtime measured "
                         "too, in the same run")
    a = ap.parse_args()
    base, n_base = bare(a.window, a.settle)
    trees = [("", ROOT)] + ([("before: ", a.before.resolve())] if a.before else [])
    out = {"bare": base}
    print(f"  {'idle CPU, % of a core':<52} {'measured':<22} goal")
    print(f"  {f'11 bare Zenoh sessions ({n_base} processes)':<52} {base:6.2f} %")
    for label, root in trees:
        proc, n_proc = runtime("process", a.window, a.settle, root)
        thread, _ = runtime("thread", a.window, a.settle, root)
        ratio = proc / base if base else float("inf")
        what = f"{label}process mode, 10 idle behaviors ({n_proc} processes)"
        print(f"  {what:<52} {proc:6.2f} % ({ratio:.2f}x)   <= 1.5x  "
              f"{'met' if ratio <= 1.5 else 'MISSED'}")
        what = f"{label}thread mode, 10 idle behaviors"
        print(f"  {what:<52} {thread:6.2f} %{'':14}<= 0.5 %  "
              f"{'met' if thread <= 0.5 else 'MISSED'}")
        out[f"{label}process"], out[f"{label}ratio"], out[f"{label}thread"] = proc, ratio, thread
    print(json.dumps(out))


if __name__ == "__main__":
    main()
