"""Where one live HMI page's CPU goes (issue 21 item 6), side by side in one run.

`esair std run --hmi` as bench/hmi_figures.py starts it (PAPA-MAN at 115200 baud, the feet
polled at 50 Hz, the 12 servos commanded in turn by a Sweep behavior), one page in
headless chromium (1280x800), and over a window:

- the CPU of each chromium process (browser, GPU/viz, renderer, others) from /proc,
  cores;
- Chrome's own split of the page's time from a trace (devtools timeline categories):
  the self time of every traced event, per thread, in ms per second, grouped as script,
  style + layout, paint (the main thread's paint and pre-paint/layerize/commit), raster
  (the raster workers) and compositing (the compositor and viz threads);
- the frames drawn a second and the page's own drawing time (window.__hmi.stats).

Each tree (``--baseline DIR`` first, then this one) in turn. Prints figures; asserts
nothing.
Run: python bench/hmi_page_cpu.py [--window 5] [--baseline DIR] [--pages 1]
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import re
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench.hmi_figures import LIVE, HmiRun, cpu_s, tree  # noqa: E402
from bench.toolkit import CHROMIUM, CHROMIUM_ARGS  # noqa: E402

CATEGORIES = ["devtools.timeline", "disabled-by-default-devtools.timeline", "v8.execute",
              "blink", "cc", "gpu", "viz", "toplevel"]
GROUPS = [                        # (group, event names), the first that matches
    ("script", {"FunctionCall", "EvaluateScript", "v8.execute", "TimerFire", "EventDispatch",
                "FireAnimationFrame", "v8.run", "V8.GC_SCAVENGER", "MinorGC", "MajorGC",
                "RunMicrotasks", "V8.Execute", "CompileScript", "v8.compile",
                "ScheduleStyleRecalculation", "HandlePostMessage"}),
    ("style+layout", {"UpdateLayoutTree", "Layout", "RecalculateStyles", "LayoutShift",
                      "UpdateLayerTree", "IntersectionObserverController::computeIntersections",
                      "ComputeIntersections", "HitTest"}),
    ("paint", {"Paint", "PrePaint", "Layerize", "Commit", "PaintImage", "UpdateLayer",
               "PaintArtifactCompositor::Update", "LocalFrameView::RunPrePaintLifecyclePhase",
               "LocalFrameView::RunPaintLifecyclePhase"}),
]


def classify(name: str, thread: str) -> str:
    for group, names in GROUPS:
        if name in names:
            return group
    if "Raster" in thread or "Raster" in name:
        return "raster"
    if "Compositor" in thread or "Viz" in thread or "VizCompositor" in thread:
        return "composite"
    if thread == "CrRendererMain":
        return "main: other"
    return "other"


def self_times(events: list[dict]) -> tuple[dict[str, float], dict[str, float], dict]:
    """Self time (µs) of every complete event, by group and by (thread, name)."""
    threads = {(e["pid"], e["tid"]): e["args"]["name"] for e in events
               if e.get("ph") == "M" and e.get("name") == "thread_name"}
    procs = {e["pid"]: e["args"]["name"] for e in events
             if e.get("ph") == "M" and e.get("name") == "process_name"}
    spans: dict[tuple, list] = collections.defaultdict(list)
    for e in events:
        if e.get("ph") == "X" and "dur" in e:
            spans[(e["pid"], e["tid"])].append((e["ts"], e["ts"] + e["dur"], e["name"]))
    groups: dict[str, float] = collections.defaultdict(float)
    names: dict[str, float] = collections.defaultdict(float)
    for key, evs in spans.items():
        evs.sort(key=lambda x: (x[0], -x[1]))
        thread = threads.get(key, "?")
        where = f"{procs.get(key[0], '?')}/{thread}"
        stack: list[list] = []             # [end, name, child time, start]

        def close(item: list, thread: str = thread, where: str = where) -> None:
            self_us = item[0] - item[3] - item[2]
            groups[classify(item[1], thread)] += self_us
            names[f"{where}/{item[1]}"] += self_us
        for start, end, name in evs:
            while stack and stack[-1][0] <= start:
                close(stack.pop())
            if stack:
                stack[-1][2] += end - start if end <= stack[-1][0] else stack[-1][0] - start
            stack.append([end, name, 0.0, start])
        while stack:
            top = stack.pop()
            close(top)
    return groups, names, procs


def js_self(prof: dict, dt: float) -> list[tuple[float, str]]:
    """The page's script by function (self time, ms per second) from a CDP CPU profile."""
    nodes = {n["id"]: n for n in prof["nodes"]}
    deltas = prof.get("timeDeltas", [])
    acc: dict[str, float] = collections.defaultdict(float)
    for node_id, d in zip(prof.get("samples", []), deltas[1:] + [0]):
        f = nodes[node_id]["callFrame"]
        where = f"{f['functionName'] or '(anonymous)'} {f['url'].rsplit('/', 1)[-1]}:{f['lineNumber'] + 1}"
        acc[where] += d / 1000
    return sorted(((v / dt, k) for k, v in acc.items()), reverse=True)


def chromium_cpu(root_pid: int) -> dict[str, float]:
    """CPU seconds of each chromium process under this bench, by its --type."""
    out: dict[str, float] = collections.defaultdict(float)
    for pid in tree(root_pid):
        try:
            cmd = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ")
        except OSError:
            continue
        if b"chrom" not in cmd.split(b" ", 1)[0]:
            continue
        m = re.search(rb"--type=(\S+)", cmd)      # chromium rewrites its command line
        out[m.group(1).decode() if m else "browser"] += cpu_s(pid)
    return out


def run_tree(p, root: Path, args: argparse.Namespace, tmp: Path) -> dict:
    run = HmiRun(root, tmp, "thread")
    std = run.std
    out: dict = {}
    try:
        url = run.url()
        hmi = run.hmi_pid()
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        pages = []
        for _ in range(args.pages):
            page = browser.new_page(viewport={"width": 1280, "height": 800})
            page.goto(url + args.query, timeout=120_000)
            page.wait_for_function(LIVE.replace("> 2", "> 10"), timeout=120_000)
            if args.eval:
                page.evaluate(args.eval)
            pages.append(page)
        if not args.no_sweep:
            std("add", "sweep", "bench.papaman_std_comps:Sweep", "--uses", "papaman.servo.*=command",
                "-o", f"seconds={2 * args.window + 4}")
        time.sleep(1.5)
        me = os.getpid()
        stats = "() => [window.__hmi.stats.draws, window.__hmi.stats.drawMs, window.__hmi.stats.samples]"
        c0, h0, t0 = chromium_cpu(me), cpu_s(hmi), time.monotonic()
        s0 = pages[0].evaluate(stats)
        time.sleep(args.window)
        dt = time.monotonic() - t0
        c1, h1 = chromium_cpu(me), cpu_s(hmi)
        s1 = pages[0].evaluate(stats)
        out["cpu"] = {k: (c1[k] - c0.get(k, 0.0)) / dt for k in c1}
        out["hmi"] = (h1 - h0) / dt
        out["draws"] = [(b - a) / dt for a, b in zip(s0, s1)]
        browser.start_tracing(page=pages[0], categories=CATEGORIES)
        t0 = time.monotonic()
        time.sleep(args.window)
        raw = browser.stop_tracing()
        dt = time.monotonic() - t0
        trace = json.loads(raw)
        events = trace["traceEvents"] if isinstance(trace, dict) else trace
        groups, names, _ = self_times(events)
        out["groups"] = {k: v / 1000 / dt for k, v in groups.items()}     # ms per second
        out["top"] = sorted(((v / 1000 / dt, k) for k, v in names.items()), reverse=True)[:args.top]
        cdp = pages[0].context.new_cdp_session(pages[0])
        cdp.send("Profiler.enable")
        cdp.send("Profiler.setSamplingInterval", {"interval": 200})
        cdp.send("Profiler.start")
        t0 = time.monotonic()
        time.sleep(args.window)
        prof = cdp.send("Profiler.stop")["profile"]
        out["js"] = js_self(prof, time.monotonic() - t0)[:args.top]
        browser.close()
        if not args.no_sweep:
            std("remove", "sweep")
    finally:
        run.stop()
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--window", type=float, default=5.0)
    ap.add_argument("--pages", type=int, default=1)
    ap.add_argument("--top", type=int, default=25, help="the costliest events listed")
    ap.add_argument("--baseline", type=Path, default=None)
    ap.add_argument("--eval", default="", help="JavaScript run on each page before measuring "
                    "(to take a part out, e.g. \"window.__hmi.pose.draw = () => {}\")")
    ap.add_argument("--query", default="", help="appended to the page's URL, e.g. ?fps=15")
    ap.add_argument("--no-sweep", action="store_true", help="no servo commanded meanwhile")
    args = ap.parse_args()
    from playwright.sync_api import sync_playwright
    tmp = Path(tempfile.mkdtemp(prefix="bench-hmi-page-"))
    trees = ([("baseline", args.baseline.resolve())] if args.baseline else []) + [("this", ROOT)]
    load0 = os.getloadavg()[0]
    got = {}
    with sync_playwright() as p:
        for name, root in trees:
            got[name] = run_tree(p, root, args, tmp / name)
    print(f"bench/hmi_page_cpu.py, {args.pages} page(s), window {args.window:g} s, load {load0:.1f} -> "
          f"{os.getloadavg()[0]:.1f}; trees: " + ", ".join(f"{n} {r}" for n, r in trees))
    names = [n for n, _ in trees]
    print(f"{'figure':48s}" + "".join(f"{n:>14s}" for n in names))
    kinds = sorted({k for n in names for k in got[n]["cpu"]})
    for k in kinds:
        print(f"{'chromium ' + k + ', cores':48s}"
              + "".join(f"{got[n]['cpu'].get(k, 0):14.3f}" for n in names))
    print(f"{'chromium all, cores':48s}" + "".join(f"{sum(got[n]['cpu'].values()):14.3f}" for n in names))
    print(f"{'HMI process, cores':48s}" + "".join(f"{got[n]['hmi']:14.3f}" for n in names))
    print(f"{'frames drawn/s, ms drawing/s, samples/s':48s}" + "".join(
        f"{'/'.join(f'{x:.0f}' for x in got[n]['draws']):>14s}" for n in names))
    groups = sorted({k for n in names for k in got[n]["groups"]})
    for g in groups:
        print(f"{'trace: ' + g + ', ms/s':48s}"
              + "".join(f"{got[n]['groups'].get(g, 0):14.1f}" for n in names))
    for n in names:
        print(f"\n{n}: costliest traced events (self time, ms/s)")
        for ms, k in got[n]["top"]:
            print(f"  {ms:8.1f}  {k}")
        print(f"{n}: the page's script by function (self time, ms/s)")
        for ms, k in got[n]["js"]:
            print(f"  {ms:8.1f}  {k}")


if __name__ == "__main__":
    main()
