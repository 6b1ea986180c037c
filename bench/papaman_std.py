"""PAPA-MAN under STD: latency, sample age and throughput of the MIN link, side by side.

Figures (one run, every column measured in this process, medians where repeated):

1. behavior command -> actuator register write, in the emulator's virtual time: a
   behavior sends servo commands (``oMSAAA``) through the AC to the MinLink driver and
   the in-process emulator (``esair://``, real time); the send's time.monotonic() is
   mapped to virtual time by the port's pacer, and the write is the ``@`` mark of the
   matching ``W 10`` transaction in the trace (its start: 38 bit times, 0.38 ms,
   follow). The driver (papaman_std_comps.TimedMinLink) notes its pacer's origin and
   its port writes in a file, so both modes are measured (in process mode it lives in
   its own process). Side by side, in each mode: one command in flight (``duplex:
   false``, the link before issue 21 item 7) and full duplex, the feet not polled and
   polled at 8 Hz. Goals: within one tick plus the command's line time at the robot's
   baud; with the feet polled, p99 <= 1.2x the no-polling floor.
2. feet sample age when the balance watcher reads it (the example's watcher, 50 Hz
   steps, feet polled at 8 Hz): goal p99 <= one poll period + 2 ms.
3. commands per second the link sustains, one in flight, against the emulator behind
   a real pty (feet not polled): pySerial alone (write a line, read a line: the
   baseline), the Link, a behavior through STD (each waits for its reply before it
   sends again), and two behaviors at once through STD (a command waits in the
   driver's queue while one is on the line: what the link sustains), for ``x`` (the
   line's own limit: 2 bytes up to CR out, 4 back) and ``oMSAAA`` (the write waits for
   the next tick: the limit is one command per 2 ticks). Goal >= 90 % of the line.
   The real firmware also takes time between the CR and its reply (the emulator,
   like the Python core, answers at once): that turnaround is measured here in gpsim on
   the generated PIC firmware (when the toolchain is installed), and the x limit is
   also given with it: the true line limit of one-in-flight x on the robot.

Figure 1 also measures process mode's own floor side by side: the bare hop between two
processes (bench/zenoh_hop.py: a Zenoh get to a queryable in another process, handed to
a worker thread; no STD), added to the no-polling run's line-and-tick floor. With
``--baseline DIR`` (another checkout, e.g. main in a detached worktree), figure 1's runs
of both trees are interleaved, each in a process of its own (the agents import that
tree's esair_std too): the ratio of this tree to the baseline at p99, in one run.

Run: python bench/papaman_std.py [--n 200] [--figures 123] [--modes thread,process]
[--repeat1 N] [--duplex-only] [--baseline DIR]; BENCH_GC=1 in the environment: figure 1
also counts the resource host process's garbage collections over 2 ms.
Prints figures; asserts nothing. Its files (traces, notes) go in temporary folders
(``esair-bench-*``) removed after each run, also on an error or Ctrl-C
(tests/std/test_bench_tmp.py).
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

HERE = Path(__file__).resolve().parent.parent       # this checkout: bench/ and boards/
# the tree whose esair_std is measured: this checkout, or a baseline's (--baseline runs
# figure 1 in processes of each tree: ESAIR_BENCH_TREE)
ROOT = Path(os.environ.get("ESAIR_BENCH_TREE") or HERE)
sys.path.insert(0, str(HERE / "bench"))
sys.path.insert(0, str(ROOT))
# process mode: the agent processes import papaman_std_comps too
os.environ["PYTHONPATH"] = os.pathsep.join(
    [str(ROOT), str(HERE / "bench"), *filter(None, [os.environ.get("PYTHONPATH")])])

from esair_min.model.validate import load_robot  # noqa: E402
from esair_std import Runtime, StdError  # noqa: E402
from esair_std.drivers.minlink import Link, line_budget  # noqa: E402
from esair_std.drivers.minlink.emulated import EmulatedRobot  # noqa: E402

PAPAMAN = HERE / "boards" / "papaman"
EXAMPLE = "esair_std.examples.papaman.papaman_behaviors"


def free_endpoint() -> str:
    import socket

    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return f"tcp/127.0.0.1:{sock.getsockname()[1]}"


def runtime(dep: dict, mode: str) -> Runtime:
    try:                      # as esair std run does (esair_std/heap.py)
        return Runtime(dep, mode=mode, endpoint=free_endpoint(), settle_heap=True)
    except TypeError:         # a baseline tree from before it
        return Runtime(dep, mode=mode, endpoint=free_endpoint())


def pct(xs: list[float], q: float) -> float:
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(q * len(xs)))]


def deployment(port: str, mode: str, behaviors: dict, feet_hz: float = 0) -> dict:
    uses = {"papaman.servo.*": "command", "papaman.motion": "command"}
    return {"robot": "papaman", "mode": mode,
            "resources": {"papaman": {"class": "esair_std.drivers.minlink:MinLink",
                                      "robot": str(PAPAMAN), "port": port,
                                      "feet_hz": feet_hz, "allow": {"*": "command"}}},
            "behaviors": {name: dict(b, uses=b.get("uses", uses))
                          for name, b in behaviors.items()}}


def wait(rt: Runtime, name: str, key: str, timeout: float = 120) -> dict:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        try:
            v = rt.get(name, timeout=2.0)
        except StdError:                  # busy while its run() runs
            v = None
        if v and v.get(key):
            return v
        time.sleep(0.05)
    raise SystemExit(f"{name} did not finish")


def command_to_write(mode: str, n: int, feet_hz: float, goal_ms: float,
                     duplex: bool = True) -> dict:
    """Figure 1: behavior send -> register write (virtual time), in ms; split at the
    moment the link writes the line to the port (``host``: send -> port write, the STD
    and Link path; ``robot``: port write -> register write, the line time and the wait
    for the tick, in the emulator alone). The driver (bench/papaman_std_comps.py,
    TimedMinLink) notes its robot's pacer origin and its port writes in a file: the
    same in thread and process mode (where it lives in its own process). Its files go
    in a temporary folder removed after (also on an error or Ctrl-C)."""
    with tempfile.TemporaryDirectory(prefix="esair-bench-") as tmp:
        return _command_to_write(Path(tmp), mode, n, feet_hz, duplex)


def _command_to_write(tmp: Path, mode: str, n: int, feet_hz: float, duplex: bool) -> dict:
    trace, notes = tmp / "trace.txt", tmp / "notes.jsonl"
    url = f"esair://{PAPAMAN}?trace={trace}"
    dep = deployment(url, mode, {"stepper": {"class": "papaman_std_comps:Stepper",
                                             "n": n, "every": 0.0373}}, feet_hz)
    dep["resources"]["papaman"].update({"class": "papaman_std_comps:TimedMinLink",
                                        "notes": str(notes), "duplex": duplex})
    with runtime(dep, mode) as rt:
        got = wait(rt, "stepper", "done")
    rows = [json.loads(line) for line in notes.read_text().splitlines()]
    origin = rows[0]
    written = [r["written"] for r in rows[1:]]
    sent = [origin["t0_virtual"] + (t - origin["t0_wall"]) * origin["factor"]
            for t in got["sent"]]
    writes, mark = [], 0.0
    for line in trace.read_text().splitlines():
        if line.startswith("@ "):
            mark = int(line[2:]) / 1e6
        elif line.startswith("W 10 ") and len(line.split()[2]) == 6:
            writes.append(mark)             # the write starts (its 38 bit times follow)
    lat = [(w - s) * 1e3 for s, w in zip(sent, writes)]
    k = len(written)
    gc_file = Path(str(notes) + ".gc")
    first = min(got["sent"], default=0.0)     # pauses while commands went (not start-up's)
    gcs = [g["ms"] for g in map(json.loads, gc_file.read_text().splitlines())
           if g.get("t", first) >= first] if gc_file.exists() else []
    return {"lat": lat, "errors": got["errors"], "gc": gcs,
            "host": [(w - s) * 1e3 for s, w in zip(sent[len(sent) - k:], written)],
            "robot": [(w - s) * 1e3 for s, w in zip(written, writes[len(writes) - k:])],
            **split_host(got["sent"][len(sent) - k:], rows[1:])}


def split_host(sent: list[float], rows: list[dict]) -> dict:
    """The host path (send -> port write, time.monotonic() in every process) in three:
    ``hop`` send -> the resource host queues it (the AC, or Zenoh between processes);
    ``queue`` queued -> the host thread runs the actuator's write(); ``link`` write() ->
    the line's port write (waiting for its turn on the line); and how many were written
    behind a reply still arriving (full duplex) or by the link's I/O thread."""
    out: dict = {"hop": [], "queue": [], "link": []}
    for s, r in zip(sent, rows):
        if r.get("asked") is None:
            continue
        out["hop"].append((r["asked"] - s) * 1e3)
        out["queue"].append((r["began"] - r["asked"]) * 1e3)
        out["link"].append((r["wall"] - r["began"]) * 1e3)
    out["behind"] = sum(r.get("behind", 0) > 0 for r in rows)
    out["by_io"] = sum(not str(r.get("by", "")).startswith("esair") for r in rows)
    return out


def pooled(runs: list[dict], goal_ms: float) -> dict:
    """The figures of several runs of one kind, their samples pooled; ``p99s``: each
    run's own p99."""
    def cat(key: str) -> list:
        return [x for r in runs for x in r[key]]
    lat, host, robot = cat("lat"), cat("host"), cat("robot")
    return {"n": len(lat), "p50": statistics.median(lat), "p90": pct(lat, 0.9),
            "p99": pct(lat, 0.99), "max": max(lat), "errors": sum(r["errors"] for r in runs),
            "p99s": [pct(r["lat"], 0.99) for r in runs],
            "host_p50": statistics.median(host), "host_p99": pct(host, 0.99),
            "robot_min": min(robot), "robot_max": max(robot), "robot_p99": pct(robot, 0.99),
            "late_ticks": sum(x > goal_ms for x in robot), "robot_n": len(robot),
            "split": {k: (statistics.median(cat(k)), pct(cat(k), 0.99))
                      for k in ("hop", "queue", "link") if cat(k)},
            "behind": sum(r["behind"] for r in runs), "by_io": sum(r["by_io"] for r in runs),
            "gc": cat("gc")}


def sample_age(mode: str, seconds: float) -> dict:
    with EmulatedRobot(PAPAMAN) as emu:
        dep = deployment(emu.port, mode, {"watcher": {
            "class": f"{EXAMPLE}:BalanceWatcher", "period": 0.02,
            "uses": {"papaman.feet": "read", "papaman.notices": "read",
                     "papaman.motion": "command"}}}, feet_hz=8)
        with runtime(dep, mode) as rt:
            time.sleep(seconds)
            w = rt.get("watcher", timeout=2.0)
    return {"samples": w["samples"], "p50": w["age_p50_ms"], "p99": w["age_p99_ms"]}


def rates(mode: str | None, n: int, senders: int = 1) -> dict:
    """Figure 3: commands per second, x and oMSAAA; the Link alone when mode is "link",
    pySerial alone (write a line, readline) when mode is "pyserial"; in STD, ``senders``
    behaviors at once share the ``n`` commands (2: the next command waits in the
    driver's queue while one is on the line: the rate the link sustains)."""
    robot = load_robot(PAPAMAN)
    out = {}
    with EmulatedRobot(PAPAMAN) as emu:
        if mode == "pyserial":
            import serial
            with serial.Serial(emu.port, b_baud(robot), timeout=2) as p:
                p.reset_input_buffer()
                for key, line in (("x", b"x\r\n"), ("o", b"odc100\r\n")):
                    t0 = time.perf_counter()
                    for _ in range(n):
                        p.write(line)
                        while p.readline().startswith(b"!"):    # the boot notice
                            pass
                    out[key] = n / (time.perf_counter() - t0)
            return out
        if mode == "link":
            with Link(robot, emu.port) as link:
                for key, line in (("x", "x"), ("o", "odc100")):
                    t0 = time.perf_counter()
                    for _ in range(n):
                        link.command(line)
                    out[key] = n / (time.perf_counter() - t0)
            return out
        for key, to, cmd in (("x", "papaman.motion", "stop"),
                             ("o", "papaman.servo.l_knee", {"angle": 100})):
            names = [f"blaster{i}" for i in range(senders)]
            dep = deployment(emu.port, mode, {name: {
                "class": "papaman_std_comps:Blaster", "to": to, "command": cmd,
                "n": n // senders} for name in names})
            with runtime(dep, mode) as rt:
                got = [wait(rt, name, "took") for name in names]
            if senders == 1:
                out[key] = n / got[0]["took"]
            else:     # commands ended while every sender was sending
                t0 = max(g["done_at"][0] for g in got)
                t1 = min(g["done_at"][-1] for g in got)
                ends = [t for g in got for t in g["done_at"] if t0 < t <= t1]
                out[key] = len(ends) / (t1 - t0)
    return out


def x_turnaround_s(robot) -> float | None:
    """The PIC firmware's turnaround of ``x`` in gpsim: from its ISR's read of the CR
    (RCREG) to the reply's first byte in TXREG, worst of 10 lines one tick apart (in
    seconds), or None without the toolchain."""
    try:
        from esair_min.codegen import generate_robot
        from esair_min.pic.build import build_board, toolchain
        from esair_min.pic.gpsim_harness import GpsimSetup, run_stimulus

        tc = toolchain()
        with tempfile.TemporaryDirectory(prefix="esair-bench-") as tmp:
            generate_robot(robot, Path(tmp) / "gen")
            build_board(Path(tmp) / "gen" / "central", tc)
            cod = Path(tmp) / "gen" / "central" / "build-pic" / "firmware.cod"
            run = run_stimulus(robot, "boot\n" + "rx x\\r\ntick 1\n" * 10, cod,
                               Path(tmp) / "run", tc)
    except Exception as exc:  # noqa: BLE001 - a bench: say why and go on
        print(f"   (no gpsim figure: {str(exc).splitlines()[0] if str(exc) else exc!r})")
        return None
    crs = [c for c, b in run.rx if b == 0x0D]
    worst = max(next(c for c, _ in run.tx if c > cr) - cr for cr in crs)
    return worst / GpsimSetup.from_robot(robot).cycles_per_second


def b_baud(robot) -> int:
    return line_budget(robot).baud


def one_run(tree: Path | None, mode: str, n: int, hz: float, goal_ms: float,
            duplex: bool) -> dict:
    """One command_to_write run, here (``tree`` None) or in a process of its own that
    imports ``tree``'s esair_std (its agents too: they start in that tree)."""
    if tree is None:
        return command_to_write(mode, n, hz, goal_ms, duplex)
    env = dict(os.environ, ESAIR_BENCH_TREE=str(tree))
    env.pop("PYTHONPATH", None)             # set again, for that tree, by the child
    out = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--one",
                          f"{mode}:{int(duplex)}:{hz:g}", "--n", str(n)],
                         cwd=tree, env=env, capture_output=True, text=True, timeout=600)
    if out.returncode != 0:
        raise SystemExit(f"figure 1 run in {tree} failed:\n{out.stderr}")
    return json.loads(out.stdout.splitlines()[-1])


def hop_floor(runs: list[dict], hops: list[dict]) -> float:
    """Process mode's floor at p99 (ms): the no-polling runs' port write -> register
    write times (line and tick) plus the bare two-process hop (send -> a worker thread
    in another process), every pair of the two samples taken: the p99 of their sum."""
    robot = sorted(x for r in runs for x in r["robot"])
    hop = sorted(x for h in hops for x in h["totals"])
    sums = sorted(a + b for a in robot for b in hop)
    return pct(sums, 0.99)


def figure1(args, modes: list[str], goal1: float) -> None:
    """Figure 1 side by side: each mode, one command in flight (``duplex: false``, the
    link before issue 21 item 7) and full duplex, with the feet not polled and polled
    at 8 Hz; ``--repeat1`` rounds, the runs interleaved (the load moves), their samples
    pooled; each round also measures the bare hop (bench/zenoh_hop.py) for process
    mode's floor. ``--baseline DIR``: every kind also in that tree, interleaved."""
    import zenoh_hop

    trees: list[tuple[str, Path | None]] = [("this", None)]
    if args.baseline:
        trees = [("this", HERE), ("baseline", Path(args.baseline).resolve())]
    runs: dict[tuple[str, str, bool, float], list[dict]] = {}
    hops: dict[str, list[dict]] = {"two processes": [], "one process": []}
    kinds = [(t, m, duplex, hz) for m in modes
             for duplex in ((True,) if args.duplex_only else (False, True)) for hz in (0, 8)
             for t, _ in trees]
    where = dict(trees)
    for i in range(args.repeat1):
        for kind in kinds:
            runs.setdefault(kind, []).append(one_run(where[kind[0]], kind[1], args.n, kind[3],
                                                     goal1, kind[2]))
        if "process" in modes:
            hops["two processes"].append(zenoh_hop.two_processes(args.n, 0.0373))
            hops["one process"].append(zenoh_hop.one_process(args.n, 0.0373))
        print(f"   (round {i + 1} of {args.repeat1} done, load average "
              f"{os.getloadavg()[0]:.1f})", flush=True)
    res = {kind: pooled(rs, goal1) for kind, rs in runs.items()}
    for (t, m, duplex, hz), r in res.items():
        floor = res[(t, m, duplex, 0)]
        what = "full duplex" if duplex else "one in flight"
        tag = f"{m} [{t}]" if args.baseline else m
        print(f"   {tag:8s} {what:14s} feet {hz} Hz  n={r['n']}  p50 {r['p50']:.2f} ms  "
              f"p90 {r['p90']:.2f} ms  p99 {r['p99']:.2f} ms  max {r['max']:.2f} ms  "
              f"errors {r['errors']}  (each run's p99: "
              f"{', '.join(f'{x:.1f}' for x in r['p99s'])} ms)")
        print(f"   {'':8s} {'':14s} {'':9s} send -> port write (STD + Link): p50 "
              f"{r['host_p50']:.2f} ms  p99 {r['host_p99']:.2f} ms;  port write -> register "
              f"write (line + tick wait): {r['robot_min']:.2f} .. {r['robot_max']:.2f} ms, "
              f"p99 {r['robot_p99']:.2f} ms (the line-and-tick floor)")
        if r["split"]:
            print(f"   {'':8s} {'':14s} {'':9s} host path split, p50/p99 ms: " + ", ".join(
                f"{k} {a:.2f}/{b:.2f}" for k, (a, b) in r["split"].items())
                + f"; written behind a reply {r['behind']}, by the I/O thread {r['by_io']}"
                + (f"; GC pauses over 2 ms in the resource host's process: {len(r['gc'])}, "
                   f"longest {max(r['gc']):.0f} ms" if r["gc"] else ""))
        extra = ""
        if m == "process" and hops["two processes"]:
            pf = hop_floor(runs[(t, m, duplex, 0)], hops["two processes"])
            extra = f", {r['p99'] / pf:.2f}x process mode's floor ({pf:.2f} ms)"
        if args.baseline and t == "this" and ("baseline", m, duplex, hz) in res:
            extra += f"; {r['p99'] / res[('baseline', m, duplex, hz)]['p99']:.2f}x the baseline's p99"
        print(f"   {'':8s} {'':14s} {'':9s} p99 = {r['p99'] / floor['robot_p99']:.2f}x the "
              f"no-polling run's line-and-tick floor, {r['p99'] / floor['p99']:.2f}x the "
              f"no-polling run's p99{extra}; missed the first tick after their line: "
              f"{r['late_ticks']} of {r['robot_n']}")
    for name, hs in hops.items():
        if hs:
            tot = [x for h in hs for x in h["totals"]]
            hop = [x for h in hs for x in h["hops"]]
            each = ", ".join(f"{h['total'][1]:.1f}" for h in hs)
            print(f"   bare hop, {name} (bench/zenoh_hop.py, send -> a worker thread, no STD): "
                  f"p50 {statistics.median(tot):.2f} ms, p99 {pct(tot, 0.99):.2f} ms (each "
                  f"run's p99: {each} ms; the "
                  f"Zenoh part alone p99 {pct(hop, 0.99):.2f} ms)")
    if hops["two processes"]:
        print("   process mode's floor: the p99 of (the no-polling run's port write -> register "
              "write) + (the bare hop between two processes), every pair of samples")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=200, help="commands per figure")
    ap.add_argument("--age-seconds", type=float, default=10.0)
    ap.add_argument("--repeat", type=int, default=3, help="figure 3: runs (median)")
    ap.add_argument("--modes", default="thread,process", help="comma-separated STD modes")
    ap.add_argument("--figures", default="123", help="which figures (e.g. 1, 23)")
    ap.add_argument("--repeat1", type=int, default=1,
                    help="figure 1: rounds, interleaved, samples pooled")
    ap.add_argument("--duplex-only", action="store_true",
                    help="figure 1: full duplex only (not the one-in-flight runs)")
    ap.add_argument("--baseline", metavar="DIR",
                    help="figure 1: also run every kind in that checkout, interleaved")
    ap.add_argument("--one", metavar="MODE:DUPLEX:HZ", help=argparse.SUPPRESS)
    args = ap.parse_args()
    robot = load_robot(PAPAMAN)
    b = line_budget(robot)
    goal1 = (b.tick_s + b.line_s(len("odc100\r\n") - 1)) * 1e3
    if args.one:                      # one figure 1 run for --baseline: its JSON
        m, duplex, hz = args.one.split(":")
        print(json.dumps(command_to_write(m, args.n, float(hz), goal1, duplex == "1")))
        return
    lim_x = 1 / b.command_s(3, 4, False)
    lim_o = 1 / b.command_s(8, 4, True)
    modes = args.modes.split(",")
    print(f"PAPA-MAN at {b.baud} baud, tick {b.tick_s * 1e3:.2f} ms; load average "
          f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    print(f"\n1. behavior command -> register write (virtual time; goal <= {goal1:.2f} ms "
          f"= tick + line time of oMSAAA; with the feet polled at 8 Hz: p99 <= 1.2x the "
          f"no-polling floor)")
    if "1" in args.figures:
        figure1(args, modes, goal1)
    if "2" not in args.figures and "3" not in args.figures:
        return
    print("\n2. feet sample age at the watcher's read (goal p99 <= 125 + 2 ms)")
    for m in modes if "2" in args.figures else []:
        r = sample_age(m, args.age_seconds)
        print(f"   {m:8s} samples={r['samples']}  p50 {r['p50']:.1f} ms  p99 {r['p99']:.1f} ms"
              f"  ({r['p99'] / 127:.0%} of the goal at p99)")
    if "3" not in args.figures:
        return
    turn = x_turnaround_s(robot)
    lim_xf = None if turn is None else 1 / (1 / lim_x + turn)
    print(f"\n3. commands per second, median of {args.repeat} (limits: x {lim_x:.1f}/s, "
          f"oMSAAA {lim_o:.1f}/s; goal >= 90 %)")
    if lim_xf is not None:
        print(f"   the PIC firmware's x turnaround (gpsim, CR read -> reply's first byte in "
              f"TXREG): {turn * 1e3:.3f} ms, so on the robot x is limited to {lim_xf:.1f}/s "
              f"(the emulator answers at once: its limit is the line's, {lim_x:.1f}/s)")
    runs: dict[str, list[dict]] = {}
    for _ in range(args.repeat):                  # interleaved: the load moves
        for m in ["pyserial", "link", *modes]:
            runs.setdefault(m, []).append(rates(m, args.n))
        for m in modes:
            runs.setdefault(f"{m} x2", []).append(rates(m, args.n, senders=2))
        if "process" in modes:
            from zenoh_floors import zenoh_get_round_trip   # a raw zenoh get
            runs.setdefault("zenoh", []).append({"rt": zenoh_get_round_trip(500)})
    med = {m: {k: statistics.median(x[k] for x in rs) for k in rs[0]} for m, rs in runs.items()}
    for m, r in med.items():
        if m == "zenoh":
            continue
        vs_fw = "" if lim_xf is None else f", {r['x'] / lim_xf:.0%} of the robot's"
        what = f"{m[:-3]}, 2 behaviors at once" if m.endswith(" x2") else m
        print(f"   {what:28s} x {r['x']:6.1f}/s ({r['x'] / lim_x:.0%} of the line{vs_fw})   "
              f"oMSAAA {r['o']:5.1f}/s ({r['o'] / lim_o:.0%})")
    if "zenoh" in med:
        rt = med["zenoh"]["rt"]
        floor = 1 / (1 / med["link"]["x"] + rt)
        print(f"   one in flight, process mode's floor: the Link alone plus one raw zenoh get "
              f"between two processes ({rt * 1e3:.3f} ms): x {floor:.1f}/s "
              f"({floor / lim_x:.0%} of the line)")
    print("   (one in flight: a behavior waits for each reply before it sends again; 2 "
          "behaviors at once: the next command waits in the driver's queue while one is on "
          "the line, the rate the link sustains)")


if __name__ == "__main__":
    main()
