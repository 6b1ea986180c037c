"""PAPA-MAN's commands per second with the HMI's pages open (issue 21 item 6: "10 browsers
open leave PAPA-MAN's commands per second (bench/papaman_std.py) within 5 % of none").

bench/papaman_std.py's figure 3 as it is (the bundled PAPA-MAN board files at their own
9600 baud, the emulated robot behind a real pty, behaviors sending through STD, one in
flight and two at once), with the feet polled at 8 Hz (the driver's default: the HMI's
feet plot needs them), in three arms interleaved round by round (the load moves):

- none: no HMI;
- hmi: the HMI (``esair std hmi``, its own process), no page: what its polling of the
  runtime (``ls``, ``inspect``, behaviors' ``get``) and its subscriptions cost;
- browser: the headless chromium with N pages on about:blank, no HMI: what the browser
  costs by itself;
- blank: the HMI (``esair std hmi``, its own process, as ``esair std run --hmi`` starts
  it) and a headless chromium with N pages on about:blank;
- live: the same with the N pages live on the HMI (each showing the feet, the pose, the
  link bar and every command the behaviors send);
- floor (``--floor``): the same N pages, each the least a live page can be in this
  browser: a page of the HMI's origin (served by the bench through Playwright's routing)
  that opens the same WebSocket, parses every message and shows the count of samples in
  one line of text, at most once a frame. Its ratio to none is what any live page costs
  here: the floor the goal is measured against.

- ARM@base (``--baseline DIR``, e.g. ``--arms none,hmi,hmi@base,live,live@base``): the
  arm with the HMI of another tree (a detached worktree of main), against this tree's
  runtime: the HMI's asking before and after, side by side.

Beside each arm, ``runtime idle``: the cores this process took over ``--idle`` seconds
before the commands (the feet polled, the HMI asking, nothing commanded): what the HMI
costs the runtime, a figure the machine's load moves far less than commands/s.

Goal: live / none >= 0.95 for the robot's commands per second. ``--pinned`` also runs the
browser pinned to one core at nice 19 (a stand-in for the remote center's own computer,
as in bench/hmi_figures.py). Beside each arm: the CPU (cores) of this process (the thread-mode
runtime and the robot's link), the HMI, the browser and the computer.

Run: python bench/papaman_commands_with_hmi.py [--pages 10] [--rounds 3] [--n 200] [--mode thread]
[--arms none,hmi,browser,blank,live] [--baseline DIR] [--idle 3] [--pinned]. Prints figures; asserts nothing.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

import papaman_std as ps  # noqa: E402  (sets PYTHONPATH for process mode's agents)
from hmi_figures import LIVE, busy_s, cpu_of, pinned_chromium, tree  # noqa: E402

from esair_std import Runtime  # noqa: E402
from esair_std.drivers.minlink.emulated import EmulatedRobot  # noqa: E402
from esair_std.hmi.child import HmiChild  # noqa: E402
from toolkit import CHROMIUM, CHROMIUM_ARGS  # noqa: E402

FEET_HZ = 8.0
FLOOR_PAGE = """<!doctype html><title>floor</title><p id=n>0</p><script>
const ws = new WebSocket(`ws://${location.host}/ws`); let n = 0, asked = false;
const el = document.getElementById("n");
ws.onmessage = (e) => { const m = JSON.parse(e.data); if (m.t === "b") n += m.m.length;
  if (!asked) { asked = true; requestAnimationFrame(() => { asked = false; el.textContent = n; }); } };
window.__floor = () => n;
</script>"""
KINDS = (("x", "papaman.motion", "stop"), ("o", "papaman.servo.l_knee", {"angle": 100}))


def roles(hmi: HmiChild | None) -> dict[str, list[int]]:
    """This process's tree by role: the browser (Playwright's driver and chromium), the
    HMI, the emulated robot (its MCUs: not the host's work) and the runtime (this process
    and, in process mode, its agents)."""
    out: dict[str, list[int]] = {"runtime": [], "hmi": [], "robot": [], "browser": []}
    hmis = set(tree(hmi.proc.pid)) if hmi is not None and hmi.proc is not None else set()
    for pid in tree(os.getpid()):
        try:
            cmd = Path(f"/proc/{pid}/cmdline").read_bytes()
        except OSError:
            continue
        if pid in hmis:
            out["hmi"].append(pid)
        elif b"chrom" in cmd or b"playwright" in cmd or b"node" in cmd.split(b"\0")[0]:
            out["browser"].append(pid)
        elif b"emulate" in cmd.split(b"\0"):
            out["robot"].append(pid)
        else:
            out["runtime"].append(pid)
    return out


def cpu_ns(pids: list[int]) -> int:
    """CPU time of these processes' threads so far, ns (schedstat: finer than the ticks
    of /proc/PID/stat, which a few seconds of a quiet process would round away)."""
    total = 0
    for pid in pids:
        try:
            tasks = os.listdir(f"/proc/{pid}/task")
        except OSError:
            continue
        for t in tasks:
            try:
                total += int(Path(f"/proc/{pid}/task/{t}/schedstat").read_text().split()[0])
            except (OSError, ValueError, IndexError):
                pass
    return total


def one(mode: str, n: int, senders: int, arm: str, browser, pages_n: int,
        baseline: Path | None = None, idle_s: float = 0.0) -> dict:
    """One run of one arm: commands/s of each kind, and the cores taken meanwhile (and
    before, ``idle_s`` with nothing commanded: the feet polled, the HMI's asking). An arm
    named ``<arm>@base`` is ``<arm>`` with the HMI of the tree ``baseline``."""
    out: dict = {}
    root = None
    if arm.endswith("@base"):
        arm, root = arm[: -len("@base")], baseline
    with EmulatedRobot(ps.PAPAMAN) as emu:
        dep = ps.deployment(emu.port, mode, {}, feet_hz=FEET_HZ)
        with Runtime(dep, mode=mode, endpoint=ps.free_endpoint(), settle_heap=True,
                     control=True) as rt:     # control: the HMI's endpoint, in every arm
            hmi = None
            pages = []
            try:
                url = ""
                if arm not in ("none", "browser"):
                    hmi = HmiChild(rt.endpoint, "127.0.0.1:0", root=root)
                    url = hmi.start()
                if arm not in ("none", "hmi"):
                    pages = [browser.new_page(viewport={"width": 1280, "height": 800})
                             for _ in range(pages_n)]
                    for page in pages:
                        if arm == "floor":
                            page.route(url.rstrip("/") + "/floor.html", lambda route: route.fulfill(
                                status=200, content_type="text/html", body=FLOOR_PAGE))
                            page.goto(url.rstrip("/") + "/floor.html", timeout=120_000)
                        else:
                            page.goto(url if arm == "live" else "about:blank", timeout=120_000)
                    for page in pages:
                        if arm == "live":
                            page.wait_for_function(LIVE, timeout=120_000)
                        elif arm == "floor":
                            page.wait_for_function("() => window.__floor() > 2", timeout=120_000)
                if arm != "none":
                    time.sleep(1.0)            # the pages' first drawing done
                pids = roles(hmi)
                if idle_s:
                    c0, t0 = cpu_ns(pids["runtime"]), time.monotonic()
                    time.sleep(idle_s)
                    out["idle"] = (cpu_ns(pids["runtime"]) - c0) / 1e9 / (time.monotonic() - t0)
                c0 = {k: cpu_of(v) for k, v in pids.items()}
                b0, t0 = busy_s(), time.monotonic()
                for key, to, cmd in KINDS:
                    names = [f"blaster{i}" for i in range(senders)]
                    for name in names:
                        rt.add(name, "papaman_std_comps:Blaster",
                               uses={"papaman.servo.*": "command", "papaman.motion": "command"},
                               options={"to": to, "command": cmd, "n": n // senders})
                    got = [ps.wait(rt, name, "took") for name in names]
                    for name in names:
                        rt.remove(name)
                    if senders == 1:
                        out[key] = n / got[0]["took"]
                    else:
                        a = max(g["done_at"][0] for g in got)
                        b = min(g["done_at"][-1] for g in got)
                        ends = [t for g in got for t in g["done_at"] if a < t <= b]
                        out[key] = len(ends) / (b - a)
                    out["errors"] = out.get("errors", 0) + sum(g["errors"] for g in got)
                dt = time.monotonic() - t0
                out["cores"] = {k: (cpu_of(v) - c0[k]) / dt for k, v in pids.items()}
                out["cores"]["machine"] = (busy_s() - b0) / dt
            finally:
                for page in pages:
                    page.close()
                if hmi is not None:
                    hmi.stop()
    return out


def runs_of(runs: list[dict], key: str) -> str:
    return ",".join(f"{r[key]:.1f}" for r in runs)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pages", type=int, default=10)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--n", type=int, default=200, help="commands per kind per run")
    ap.add_argument("--mode", default="thread", choices=["thread", "process"])
    ap.add_argument("--senders", default="1,2", help="behaviors at once: 1 (one in flight), "
                    "2 (what the link sustains)")
    ap.add_argument("--arms", default="none,hmi,browser,blank,live",
                    help="which arms, interleaved in this order (none is the reference)")
    ap.add_argument("--baseline", type=Path, default=None,
                    help="another tree (a detached worktree of main): arms ARM@base run its HMI")
    ap.add_argument("--idle", type=float, default=3.0,
                    help="seconds of the runtime's CPU measured before the commands (0: none)")
    ap.add_argument("--floor", action="store_true",
                    help="also the least live page (a WebSocket and one line of text)")
    ap.add_argument("--pinned", action="store_true",
                    help="also with the browser pinned to one core at nice 19")
    args = ap.parse_args()
    from playwright.sync_api import sync_playwright

    robot = ps.load_robot(ps.PAPAMAN)
    b = ps.line_budget(robot)
    lim = {"x": 1 / b.command_s(3, 4, False), "o": 1 / b.command_s(8, 4, True)}
    print(f"PAPA-MAN at {b.baud} baud, feet polled at {FEET_HZ:g} Hz, {args.mode} mode, "
          f"{args.pages} pages; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    print(f"line limits: x {lim['x']:.1f}/s, oMSAAA {lim['o']:.1f}/s")
    arms = args.arms.split(",") + (["floor"] if args.floor else [])
    if "none" not in arms:
        ap.error("--arms must include none (the reference)")
    with tempfile.TemporaryDirectory(prefix="esair-bench-") as tmp, sync_playwright() as p:
        browsers = [("free", CHROMIUM)]
        if args.pinned:
            browsers.append(("pinned", pinned_chromium(Path(tmp), 19)))
        for how, exe in browsers:
            # the floor page is fulfilled by Playwright, not fetched: chromium would take it
            # for a public page and refuse its WebSocket to 127.0.0.1 (local network access)
            browser = p.chromium.launch(executable_path=exe, args=CHROMIUM_ARGS + [
                "--disable-features=LocalNetworkAccessChecks"])
            try:
                for senders in (int(s) for s in args.senders.split(",")):
                    runs: dict[str, list[dict]] = {a: [] for a in arms}
                    loads = []
                    for _ in range(args.rounds):
                        for arm in arms:
                            loads.append(os.getloadavg()[0])
                            runs[arm].append(one(args.mode, args.n, senders, arm, browser,
                                                 args.pages, args.baseline, args.idle))
                    what = "one in flight" if senders == 1 else f"{senders} behaviors at once"
                    print(f"\nbrowser {how}, {what} (median of {args.rounds}; load "
                          f"{min(loads):.1f}-{max(loads):.1f}):")
                    med = {a: {k: statistics.median(r[k] for r in runs[a]) for k in ("x", "o")}
                           for a in arms}
                    for a in arms:
                        cores = {k: statistics.median(r["cores"].get(k, 0.0) for r in runs[a])
                                 for k in ("runtime", "hmi", "robot", "browser", "machine")}
                        errs = sum(r["errors"] for r in runs[a])
                        idle = (f"  runtime idle {statistics.median(r['idle'] for r in runs[a]):.4f}"
                                if args.idle else "")
                        mx, mo = med[a]["x"], med[a]["o"]
                        print(f"  {a:10s} x {mx:6.1f}/s ({mx / med['none']['x']:.3f}x none; runs "
                              f"{runs_of(runs[a], 'x')})  oMSAAA {mo:5.1f}/s "
                              f"({mo / med['none']['o']:.3f}x; runs {runs_of(runs[a], 'o')})  "
                              f"errors {errs}  cores " + " ".join(f"{k} {v:.2f}" for k, v in cores.items())
                              + idle)
                    for k, name in (("x", "x"), ("o", "oMSAAA")) if "live" in med else ():
                        r = med["live"][k] / med["none"][k]
                        floor = (f"; the least live page's: {med['floor'][k] / med['none'][k]:.3f}x, "
                                 f"so the HMI's page is {r / (med['floor'][k] / med['none'][k]):.3f}x"
                                 f" of that floor" if "floor" in med else "")
                        print(f"  {name}: {args.pages} live pages / none = {r:.3f}x "
                              f"(goal >= 0.95x: {'met' if r >= 0.95 else 'NOT met'}){floor}")
            finally:
                browser.close()


if __name__ == "__main__":
    main()
