"""The HMI's figures (issue 21 item 6), side by side in one run.

`esair std run DEPLOYMENT --hmi` with PAPA-MAN's board files at 115200 baud (a bench-only
copy: at 9600 baud the line allows at most 9.9 feet polls a second) and the feet polled at
50 Hz by its emulated robot, then, in headless chromium (Debian's):

0. during figures 1-3 a behavior (Sweep) commands the 12 servos in turn, one in flight,
   as fast as the link answers (about one command per 2 ticks: ~55/s);

1. sample -> pixel: the sensor's time stamp (time.time() when reported) to the
   requestAnimationFrame that drew it on the feet plot (performance.timeOrigin + now(),
   the same clock on this one computer), every sample of one page (the operator's
   browser) over the window: goal p99 <= 50 ms; split at the moment the page got it
   (the rest is the browser's wait for a frame). Beside it the same of 3 pages at once
   (figure 2's condition), whose 3 renderers share this computer's 2 cores with the
   robot and the HMI, and with ``--floor`` that of 3 least pages under the same load;
2. the HMI process's CPU (utime + stime from /proc over the window) with no page and with
   3 pages open; goal <= 10 % of one core with 3;
3. its RSS with 3 pages; goal <= 45 MB;
4. page weight: the bytes of every response the page loads; goal <= 300 KB;
5. commands per second through the runtime (the `command` verb, `x`, one in flight, as
   the principal hmi) with 10 pages open on the HMI and with the same 10 on about:blank
   (no socket, nothing drawn), ``--rounds`` times interleaved, medians; goal within 5 %;
   beside it the CPU (cores) of the runtime (with the HMI and the emulator), of the
   browser, of this bench and of the whole computer in those windows;
6. a 1 kHz sensor (esair_std.drivers.sim:Counter) recorded by `esair std record`'s
   Recorder: samples lost (gaps in seq + queue drops); goal 0.

The 10 pages compete with everything else for this computer's cores (chromium renders
each at 50 Hz): run it on a quiet machine, and read the load printed with the figures.

Each figure of this tree beside the same of a baseline tree (``--baseline DIR``, e.g. a
detached worktree of main: its runtime, HMI and page, run one after the other in this
one run); sample -> pixel is split into its hops (the sample's time stamp -> the HMI
process got it -> it sent it -> the page got it -> the frame that drew it); each page's
browser CPU (the whole browser's CPU over the pages open); commands/s both with the
browser free (unpinned) and with the browser pinned to one core at nice 19
(``taskset``), a stand-in for the remote center's own computer: the ratio to the same
browser with its pages on about:blank is the floor the page itself adds.

Run: python bench/hmi_figures.py [--window 10] [--mode thread] [--baseline DIR]. Prints figures;
asserts nothing.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from esair_std.record import Recorder, read_samples  # noqa: E402
from esair_std.transport.bus import Bus  # noqa: E402
from bench.toolkit import CHROMIUM, CHROMIUM_ARGS, free_port, wait_for  # noqa: E402

TICK = os.sysconf("SC_CLK_TCK")


def fast_robot(tmp: Path) -> Path:
    folder = tmp / "papaman"
    shutil.copytree(ROOT / "boards" / "papaman", folder)
    central = folder / "central.yaml"
    central.write_text(central.read_text().replace("baud: 9600", "baud: 115200"))
    return folder


def deployment(tmp: Path, mode: str) -> Path:
    dep = {"robot": "papaman", "mode": mode, "endpoint": "tcp/127.0.0.1:7447",
           "resources": {"papaman": {
               "class": "esair_std.drivers.minlink:MinLink", "robot": str(fast_robot(tmp)),
               "port": "emulate", "emulate": {"scenario": "quiet"}, "feet_hz": 50,
               "allow": {"*": "read", "hmi": "command", "sweep": "command"}}}}
    path = tmp / "bench.yaml"
    path.write_text(json.dumps(dep))
    return path


def children(pid: int) -> list[tuple[int, bytes]]:
    out = []
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                stat = Path(f"/proc/{d}/stat").read_text()
                cmd = Path(f"/proc/{d}/cmdline").read_bytes()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                out.append((int(d), cmd))
    return out


def cpu_s(pid: int) -> float:
    try:
        f = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:                      # it ended meanwhile
        return 0.0
    return (int(f[11]) + int(f[12])) / TICK


def tree(pid: int) -> list[int]:
    """``pid`` and every process below it."""
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        out.append(p)
        todo += [c for c, _ in children(p)]
    return out


def cpu_of(pids: list[int]) -> float:
    return sum(cpu_s(p) for p in pids)


class CpuWindow:
    """CPU seconds per second of wall time of some process trees over a window, and of
    the whole computer (/proc/stat: all cores' busy time)."""

    def __init__(self, runtime: int):
        rt = tree(runtime)
        me = os.getpid()
        self.pids = {"runtime": rt, "browser": [p for p in tree(me) if p != me and p not in rt],
                     "bench": [me]}
        self.c0 = {name: cpu_of(p) for name, p in self.pids.items()}
        self.all0, self.t0 = busy_s(), time.monotonic()

    def shares(self) -> dict[str, float]:
        dt = time.monotonic() - self.t0
        out = {name: (cpu_of(p) - self.c0[name]) / dt for name, p in self.pids.items()}
        out["machine"] = (busy_s() - self.all0) / dt
        return out


def busy_s() -> float:
    f = Path("/proc/stat").read_text().splitlines()[0].split()[1:]
    idle = int(f[3]) + int(f[4])
    return (sum(int(x) for x in f[:8]) - idle) / TICK


def rss_mb(pid: int) -> float:
    m = re.search(r"VmRSS:\s+(\d+) kB", Path(f"/proc/{pid}/status").read_text())
    return int(m.group(1)) / 1024 if m else float("nan")


def cpu_share(pid: int, window: float) -> float:
    c0, t0 = cpu_s(pid), time.monotonic()
    time.sleep(window)
    return (cpu_s(pid) - c0) / (time.monotonic() - t0)


def free_core() -> str:
    """The last core of this computer (where a pinned browser runs)."""
    return str(max(os.sched_getaffinity(0)))


def pinned_chromium(tmp: Path, nice: int) -> str:
    """A chromium that runs on one core at ``nice``: a stand-in for "the remote center's
    computer" on a computer that is both."""
    wrapper = tmp / "chromium-pinned"
    wrapper.write_text(f"#!/bin/sh\nexec taskset -c {free_core()} nice -n {nice} {CHROMIUM} \"$@\"\n")
    wrapper.chmod(0o755)
    return str(wrapper)


def command_rate(endpoint: str, robot: str, seconds: float) -> float:
    bus = Bus(connect=[endpoint])
    try:
        key = f"esair/{robot}/ctl/command"
        body = {"who": "hmi", "resource": "papaman.motion", "command": "stop", "timeout": 2.0}
        wait_for(lambda: bus.request(key, body, 5.0) is not None, timeout=20, what="the runtime")
        n, end = 0, time.monotonic() + seconds
        while time.monotonic() < end:
            r = bus.request(key, body, 5.0)
            if r and "ok" in r:
                n += 1
        return n / seconds
    finally:
        bus.close()


def pct(values: list[float], q: float) -> float:
    s = sorted(values)
    return s[min(len(s) - 1, int(len(s) * q))] if s else float("nan")


LIVE = ("() => window.__hmi && window.__hmi.wsUp && window.__hmi.feet && "
        "window.__hmi.feet.t.length > 2")


#: --floor: the least page that shows the feet live: the same WebSocket and messages, a
#: 10 px canvas repainted at the first frame after each feet sample, nothing else. Its
#: sample -> pixel on this computer, with the same HMI, robot and sweep, is the floor
#: the browser and the machine give any page; the real page's figure is read against it.
FLOOR_JS = """() => {
const lat = [], arr = [], fresh = [];
const now = () => performance.timeOrigin + performance.now();
const ws = new WebSocket(`ws://${location.host}/ws`);
ws.onmessage = (ev) => {
  const m = JSON.parse(ev.data), got = now();
  for (const x of (m.t === "b" ? m.m : [m]))
    if (x.t === "s" && x.r.endsWith(".feet")) { arr.push(got - x.ts * 1000); fresh.push(x.ts); }
};
const c = document.createElement("canvas"); c.width = c.height = 10;
document.body.replaceChildren(c);
const ctx = c.getContext("2d");
let k = 0;
function frame() {
  if (fresh.length) {
    const t = now();
    for (const ts of fresh) lat.push(t - ts * 1000);
    fresh.length = 0;
    ctx.fillStyle = (k++ % 2) ? "#000" : "#fff"; ctx.fillRect(0, 0, 10, 10);
  }
  requestAnimationFrame(frame);
}
requestAnimationFrame(frame);
window.__floor = { lat, arr };
}"""


def floor_figures(p, url: str, std, window: float) -> dict[str, list[float]]:
    """sample -> pixel and sample -> onmessage of 3 floor pages (FLOOR_JS, run at
    the HMI's own origin, so its Origin check passes) while the sweep runs again."""
    browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
    pages = []
    for _ in range(3):
        page = browser.new_page(viewport={"width": 1280, "height": 800})
        # a file of the HMI's own (nothing else loads), then the floor's script run in it:
        # its origin is the HMI's, as a served page's is (a page Playwright serves itself
        # is refused the WebSocket by Chromium's local network checks; the HMI's CSP
        # refuses an inline script, so it is evaluated, which CSP does not govern)
        page.goto(url.rstrip("/") + "/style.css", timeout=120_000)
        page.evaluate(FLOOR_JS)
        page.wait_for_function("() => window.__floor && window.__floor.lat.length > 10",
                               timeout=120_000)
        pages.append(page)
    std("add", "sweep", "bench.papaman_std_comps:Sweep", "--uses", "papaman.servo.*=command",
        "-o", f"seconds={window + 1.5}")
    time.sleep(1)
    for page in pages:
        page.evaluate("() => { window.__floor.lat.length = 0; window.__floor.arr.length = 0; }")
    time.sleep(window)
    out: dict[str, list[float]] = {"lat": [], "arr": []}
    for page in pages:
        got = page.evaluate("() => window.__floor")
        out["lat"] += got["lat"]
        out["arr"] += got["arr"]
    browser.close()
    time.sleep(1.0)
    std("remove", "sweep")
    return out


def split(page, names: list[str]) -> dict[str, list[float]]:
    return {n: page.evaluate(f"() => window.__hmi.stats.{n} || []") for n in names}


class HmiRun:
    """``esair std run DEPLOYMENT --hmi`` of the tree at ``root`` on a free endpoint (its
    stderr in ``tmp/run.err``), and ``esair std VERB ...`` against it."""

    def __init__(self, root: Path, tmp: Path, mode: str):
        tmp.mkdir()
        self.root, self.tmp = root, tmp
        self.ep = f"tcp/127.0.0.1:{free_port()}"
        self.env = dict(os.environ, PYTHONPATH=str(root) + os.pathsep + os.environ.get("PYTHONPATH", ""))
        self.err = open(tmp / "run.err", "w+")  # noqa: SIM115 - closed in stop()
        self.proc = subprocess.Popen([sys.executable, "-m", "esair_min.cli", "std", "run",
                                      str(deployment(tmp, mode)), "--hmi", "--hmi-listen",
                                      "127.0.0.1:0", "-e", self.ep, "--no-top"],
                                     stdout=subprocess.DEVNULL, stderr=self.err, env=self.env, cwd=root)

    def cli(self, *words: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "esair_min.cli", "std", *words, "-e", self.ep],
                              capture_output=True, text=True, env=self.env, timeout=60, cwd=self.root)

    def std(self, *words: str) -> str:
        r = self.cli(*words)
        assert r.returncode == 0, r.stderr
        return r.stdout

    def url(self) -> str:
        return wait_for(lambda: (m := re.search(r"^hmi: (\S+)$", (self.tmp / "run.err").read_text(),
                                                re.M)) and m.group(1), timeout=90, what="URL")

    def hmi_pid(self) -> int:
        return next(p for p, cmd in children(self.proc.pid) if b"hmi" in cmd.split(b"\0"))

    def stop(self) -> None:
        self.proc.send_signal(signal.SIGTERM)
        self.proc.wait(timeout=30)
        self.err.close()


def run_tree(p, root: Path, args: argparse.Namespace, tmp: Path) -> dict:
    """Every figure of the tree at ``root`` (its runtime, HMI and page)."""
    run = HmiRun(root, tmp, args.mode)
    proc, ep, std = run.proc, run.ep, run.std
    out: dict = {}

    def swept() -> dict | None:
        r = run.cli("get", "sweep")
        return json.loads(r.stdout) if r.returncode == 0 else None     # busy while it runs
    try:
        url = run.url()
        hmi = run.hmi_pid()
        time.sleep(2)
        out["cpu0"] = cpu_share(hmi, args.window)
        out["rss0"] = rss_mb(hmi)
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        pages = []
        for i in range(3):
            page = browser.new_page(viewport={"width": 1280, "height": 800})
            page.goto(url, timeout=120_000)
            try:
                page.wait_for_function(LIVE.replace("> 2", "> 10"), timeout=120_000)
            except Exception:
                print("page", i, page.evaluate("() => [window.__hmi.wsUp, window.__hmi.stats"
                      ".samples, window.__hmi.entry, JSON.stringify(window.__hmi.link)]"),
                      page.locator("#log").inner_text()[:300], file=sys.stderr)
                raise
            pages.append(page)
        out["weight"] = pages[0].evaluate(
            "() => Object.fromEntries(performance.getEntriesByType('navigation').concat("
            "performance.getEntriesByType('resource')).map(e => [e.name, e.transferSize]))")
        # the robot busy meanwhile: its 12 servos commanded in turn, as fast as the link
        # answers (bench/papaman_std_comps.py, Sweep)
        std("add", "sweep", "bench.papaman_std_comps:Sweep", "--uses", "papaman.servo.*=command",
            "-o", f"seconds={2 * args.window + 4}")
        time.sleep(1)
        keys = ["latencies", "arrivals", "hop", "hmi", "wire", "waits"]
        for page in pages:
            page.evaluate(f"() => {{ for (const k of {json.dumps(keys)}) "
                          "if (window.__hmi.stats[k]) window.__hmi.stats[k].length = 0; }")
        drawn0 = [page.evaluate("() => [window.__hmi.stats.draws, window.__hmi.stats.drawMs]")
                  for page in pages]
        win = CpuWindow(proc.pid)
        # --profile: py-spy samples the HMI in this window (its figures are then not clean)
        prof = subprocess.Popen(
            ["py-spy", "record", "-p", str(hmi), "-d", str(int(args.window)), "-r", "250",
             "--nonblocking", "--threads", "--format", "raw", "-o", str(args.profile)],
            stdout=subprocess.DEVNULL) if args.profile else None
        out["cpu3"] = cpu_share(hmi, args.window)
        if prof is not None:
            prof.wait()
        out["browser3"] = win.shares()["browser"]
        out["rss3"] = rss_mb(hmi)
        out["drawn"] = [[b - a for a, b in zip(d0, page.evaluate(
            "() => [window.__hmi.stats.draws, window.__hmi.stats.drawMs]"))]
            for d0, page in zip(drawn0, pages)]
        out["split"] = {k: [] for k in keys}
        for page in pages:
            for k, v in split(page, keys).items():
                out["split"][k] += v
        # then one page alone (the operator's browser), the sweep still on: the other two
        # closed, its figures from here
        for page in pages[1:]:
            page.close()
        time.sleep(1)
        pages[0].evaluate(f"() => {{ for (const k of {json.dumps(keys)}) "
                          "if (window.__hmi.stats[k]) window.__hmi.stats[k].length = 0; }")
        time.sleep(args.window)
        out["one"] = split(pages[0], keys)
        out["sweep"] = wait_for(lambda: swept(), timeout=30, what="the sweep's end")
        std("remove", "sweep")
        browser.close()
        if args.floor:
            out["floor"] = floor_figures(p, url, std, args.window)
        # commands/s with 10 pages on the HMI and with the same 10 on about:blank (no
        # socket, nothing drawn), interleaved --rounds times (the load moves): medians;
        # the browser free, then pinned to one core at nice 19
        out["rates"] = {}
        # the floor: no browser at all (what 10 blank pages cost is beside it)
        win = CpuWindow(proc.pid)
        out["no_browser"] = (command_rate(ep, "papaman", args.window / 2), win.shares())
        lives: dict[str, int] = {}
        out["live"] = lives
        for how, exe in [("free", CHROMIUM), ("pinned", pinned_chromium(tmp, args.nice))][:args.rates]:
            browser = p.chromium.launch(executable_path=exe, args=CHROMIUM_ARGS)
            pages = [browser.new_page(viewport={"width": 1280, "height": 800}) for _ in range(10)]
            for i, page in enumerate(pages):
                page.on("crash", lambda _p, i=i: print(f"page {i} crashed", file=sys.stderr))
            rates: dict[int, list[float]] = {0: [], 10: []}
            cpus: dict[int, list[dict]] = {0: [], 10: []}
            for r in range(2 * args.rounds):
                n = 10 if r % 2 == 0 else 0
                for page in pages:
                    page.goto(url if n else "about:blank", timeout=120_000)
                live = 0
                if n:
                    for page in pages:
                        try:           # a starved (pinned, niced) browser may not get there
                            page.wait_for_function(LIVE, timeout=90_000)
                        except Exception:  # noqa: BLE001 - counted and said
                            continue
                        live += 1
                    lives[how] = min(lives.get(how, 10), live)
                win = CpuWindow(proc.pid)
                print(f"{root.name}: browser {how}, {n} pages live, load {os.getloadavg()[0]:.1f}",
                      file=sys.stderr)
                rates[n].append(command_rate(ep, "papaman", args.window / 2))
                cpus[n].append(win.shares())
            browser.close()
            out["rates"][how] = (rates, {n: {k: statistics.median(c[k] for c in cpus[n])
                                             for k in cpus[n][0]} for n in (0, 10)})
        # 1 kHz recorded
        std("add-resource", "counter", "esair_std.drivers.sim:Counter", "-o", "rate_hz=1000",
            "--allow", "*=read")
        rec = Recorder(ep, str(tmp / "k.mcap"), ["counter"])
        rec.start()
        time.sleep(args.window / 2)
        c = rec.stop()
        seqs = [s[1] for s in read_samples(tmp / "k.mcap")]
        out["lost"] = ((seqs[-1] - seqs[0] + 1 - len(seqs)) if seqs else -1, c["dropped"], len(seqs))
    except BaseException:
        print(f"run alive: {proc.poll() is None}; its children: {children(proc.pid)}",
              file=sys.stderr)
        raise
    finally:
        run.stop()
    return out


def p50_99(values: list[float]) -> str:
    if not values:
        return "-"
    return f"{statistics.median(values):.1f} / {pct(values, 0.99):.1f}"


def rows_of(f: dict, window: float) -> list[tuple[str, str, str, float]]:
    lat, sp, one = f["split"]["latencies"], f["split"], f["one"]
    rows = [
        ("sample -> pixel, p50 / p99 ms, a page, feet at 50 Hz",
         f"{p50_99(one['latencies'])} ({len(one['latencies'])} samples)", "p99 <= 50",
         pct(one["latencies"], 0.99) / 50 if one["latencies"] else 9.9),
        ("  sample -> the page got it / -> the frame that drew it",
         f"{p50_99(one['arrivals'])}; {p50_99(one['waits'])}", "-", 0.0),
        ("the same, 3 pages on this computer's 2 cores",
         f"{p50_99(lat)} ({len(lat)} samples)", "-", 0.0),
        *([("  floor: the least live page (bench/hmi_figures.py FLOOR_JS), same load: p50 / p99",
            f"{p50_99(f['floor']['lat'])} ({len(f['floor']['lat'])} samples)", "-", 0.0),
           ("    its sample -> the page got it (onmessage)", p50_99(f["floor"]["arr"]), "-", 0.0),
           ("    p99 of the page / p99 of the floor",
            f"{pct(lat, 0.99) / max(1e-9, pct(f['floor']['lat'], 0.99)):.2f}x", "-", 0.0)]
          if "floor" in f else []),
        ("  sample -> the page got it (onmessage)", p50_99(sp["arrivals"]), "-", 0.0),
        ("    sample -> HMI process (runtime, Zenoh)", p50_99(sp["hop"]), "-", 0.0),
        ("    HMI process: got -> sent", p50_99(sp["hmi"]), "-", 0.0),
        ("    sent -> page (WebSocket, the page's thread)", p50_99(sp["wire"]), "-", 0.0),
        ("  the page got it -> the frame that drew it", p50_99(sp["waits"]), "-", 0.0),
        ("  meanwhile (both) the 12 servos commanded: sent, failed",
         f"{f['sweep']['sent']}, {f['sweep']['errors']}", "-", 0.0),
        ("  each page: frames drawn/s, ms drawing/s",
         ", ".join(f"{n / window:.0f}/{ms / window:.0f}" for n, ms in f["drawn"]), "-", 0.0),
        ("  browser CPU per page (whole browser / 3), cores", f"{f['browser3'] / 3:.3f}", "-", 0.0),
        ("HMI CPU, no page / 3 pages, % of a core",
         f"{f['cpu0'] * 100:.1f} / {f['cpu3'] * 100:.1f}", "<= 10", f["cpu3"] / 0.10),
        ("HMI RSS, no page / 3 pages, MB", f"{f['rss0']:.1f} / {f['rss3']:.1f}", "<= 45",
         f["rss3"] / 45),
        ("page weight, KB", f"{sum(f['weight'].values()) / 1024:.1f} in {len(f['weight'])}",
         "<= 300", sum(f["weight"].values()) / 1024 / 300),
    ]
    if "no_browser" in f:
        r, cpu = f["no_browser"]
        rows.append(("commands/s, no browser", f"{r:.0f} (cores runtime / machine "
                     f"{cpu['runtime']:.2f}/{cpu['machine']:.2f})", "-", 0.0))
    for how, (rates, cpu) in f["rates"].items():
        r0, r10 = statistics.median(rates[0]), statistics.median(rates[10])
        rows.append((f"commands/s, 10 pages blank / live ({f['live'].get(how, 0)} live), {how}",
                     f"{r0:.0f} / {r10:.0f} = {r10 / r0:.3f}x ("
                     f"{','.join(f'{a:.0f}' for a in rates[0])} / "
                     f"{','.join(f'{a:.0f}' for a in rates[10])})",
                     ">= 0.95x", 0.95 / (r10 / r0) if r10 else 9.9))
        rows.append(("  cores: runtime / browser / machine, blank; live",
                     f"{cpu[0]['runtime']:.2f}/{cpu[0]['browser']:.2f}/{cpu[0]['machine']:.2f}; "
                     f"{cpu[10]['runtime']:.2f}/{cpu[10]['browser']:.2f}/{cpu[10]['machine']:.2f}",
                     "-", 0.0))
    lost, dropped, n = f["lost"]
    rows.append(("record 1 kHz: lost (gaps + drops)", f"{lost} + {dropped} of {n}", "0",
                 float(lost + dropped)))
    return rows


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--window", type=float, default=10.0)
    ap.add_argument("--mode", default="thread", choices=["thread", "process"])
    ap.add_argument("--rounds", type=int, default=2,
                    help="commands/s: rounds of (10 pages, no page), interleaved, per browser")
    ap.add_argument("--baseline", type=Path, default=None,
                    help="another tree (e.g. `git worktree add --detach /tmp/base main`) run "
                         "first in the same run, its figures beside these")
    ap.add_argument("--rates", type=int, default=2, choices=[0, 1, 2],
                    help="commands/s with the browser: 0 not measured, 1 free, 2 free and pinned")
    ap.add_argument("--nice", type=int, default=19, help="the pinned browser's nice level")
    ap.add_argument("--floor", action="store_true",
                    help="also sample -> pixel of 3 least pages (FLOOR_JS) under the same "
                         "load: the floor the browser and this computer give")
    ap.add_argument("--profile", type=Path, default=None,
                    help="py-spy's collapsed stacks of the HMI with 3 pages, to this file "
                         "(that run's CPU figure then includes the sampling)")
    args = ap.parse_args()
    from playwright.sync_api import sync_playwright

    tmp = Path(tempfile.mkdtemp(prefix="bench-hmi-"))
    trees = ([("baseline", args.baseline.resolve())] if args.baseline else []) + [("this", ROOT)]
    load0 = os.getloadavg()[0]
    got = {}
    with sync_playwright() as p:
        for name, root in trees:
            got[name] = rows_of(run_tree(p, root, args, tmp / name), args.window)
    print(f"bench/hmi_figures.py, mode {args.mode}, window {args.window:g} s, load {load0:.1f} -> "
          f"{os.getloadavg()[0]:.1f}; trees: " + ", ".join(f"{n} {r}" for n, r in trees))
    names = [n for n, _ in trees]
    print(f"{'figure':54s} " + " ".join(f"{n:>40s}" for n in names) + "  goal")
    for i, (label, _, goal, _r) in enumerate(got["this"]):
        cells = " ".join(f"{got[n][i][1]:>40s}" for n in names)
        ratio = got["this"][i][3]
        verdict = "" if goal == "-" else ("met" if ratio <= 1 else "NOT met")
        print(f"{label:54s} {cells}  {goal} {verdict}")


if __name__ == "__main__":
    main()
