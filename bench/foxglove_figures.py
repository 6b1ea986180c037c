"""The live Foxglove server's figures beside the HMI's (issue 35 item 4), in one run.

`esair std run starfish --hmi --foxglove` (the sound source on, so the camera shoots),
then, each over ``--window`` seconds:

1. side by side over the same window: the HMI process with one client (a plain
   WebSocket on its /ws, read on a thread of its own: every batch it sends, read and
   dropped, as a page's socket would be) and the Foxglove server with one client
   (bench/toolkit/foxclient.py: subscribed to every channel): each process's CPU
   (utime + stime from /proc, share of one core) and RSS at the end of the window;
   goal: the Foxglove server <= the HMI;
2. sample -> client: a sample's own time stamp (time.time() when reported) to when the
   Foxglove client read its message (the same clock, one computer), every sample of the
   sensors' channels in the window: p50 / p99;
3. a 1 kHz sensor (esair_std.drivers.sim:Counter, PAPA-MAN's 1 kHz feet test rate)
   added to the robot, subscribed by the Foxglove client: samples lost (gaps in seq)
   and the server's drop counters (none are reachable from outside: the gaps are the
   loss), and samples the client got twice; goal 0.

Run: python bench/foxglove_figures.py [--window 20] [--mode thread]. Prints figures;
asserts nothing. The machine's load is printed with them: run it on a quiet machine.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from websockets.sync.client import connect  # noqa: E402

from bench.toolkit import free_endpoint, wait_for  # noqa: E402
from bench.toolkit.foxclient import FoxClient  # noqa: E402

TICK = os.sysconf("SC_CLK_TCK")


def cpu_s(pid: int) -> float:
    f = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(f[11]) + int(f[12])) / TICK


def rss_mb(pid: int) -> float:
    m = re.search(r"VmRSS:\s+(\d+) kB", Path(f"/proc/{pid}/status").read_text())
    return int(m.group(1)) / 1024 if m else float("nan")


def child(pid: int, word: bytes) -> int:
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                stat = Path(f"/proc/{d}/stat").read_text()
                cmd = Path(f"/proc/{d}/cmdline").read_bytes()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid and word in cmd.split(b"\0"):
                return int(d)
    raise RuntimeError(f"no child {word!r} of {pid}")


def pct(values: list[float], q: float) -> float:
    s = sorted(values)
    return s[min(len(s) - 1, int(q * len(s)))]


def std(ep: str, *args: str) -> str:
    r = subprocess.run([sys.executable, "-m", "esair_min.cli", "std", *args, "-e", ep],
                       capture_output=True, text=True, cwd=ROOT, timeout=60)
    if r.returncode:
        raise RuntimeError(r.stderr)
    return r.stdout


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--window", type=float, default=20.0)
    ap.add_argument("--mode", default="thread")
    args = ap.parse_args()
    ep = free_endpoint()
    tmp = Path(tempfile.mkdtemp(prefix="foxbench-"))
    err = open(tmp / "run.err", "w+")      # noqa: SIM115 - closed at the end
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.Popen([sys.executable, "-m", "esair_min.cli", "std", "run", "starfish",
                             "--hmi", "--hmi-listen", "127.0.0.1:0", "--foxglove",
                             "--foxglove-listen", "127.0.0.1:0", "--mode", args.mode, "-e", ep,
                             "--no-top"], stdout=subprocess.DEVNULL, stderr=err, env=env,
                            cwd=tmp)
    try:
        def urls():
            text = (tmp / "run.err").read_text()
            h = re.search(r"^hmi: (http://\S+)$", text, re.M)
            f = re.search(r"^foxglove: (ws://\S+)$", text, re.M)
            return h and f and (h.group(1), f.group(1))
        hmi_url, fox_url = wait_for(urls, timeout=120, what="both URLs")
        hmi_pid, fox_pid = child(proc.pid, b"hmi"), child(proc.pid, b"foxglove")
        std(ep, "configure", "starfish.mics", "source", '{"x": 1.0, "y": 3.5, "on": true}')
        time.sleep(2.0)
        out: dict = {}

        # 1-2. the HMI and the Foxglove server, one client each, the same window
        ws_url = hmi_url.replace("http://", "ws://") + "ws"
        frames = [0]
        done = threading.Event()

        def page(ws) -> None:
            while not done.is_set():
                try:
                    ws.recv(timeout=0.5)
                    frames[0] += 1
                except TimeoutError:
                    pass
        client = FoxClient(fox_url)
        with connect(ws_url, max_size=None) as ws:
            reader = threading.Thread(target=page, args=(ws,))
            reader.start()
            client.pump(2.0)
            client.got.clear()
            frames[0] = 0
            h0, f0, t0 = cpu_s(hmi_pid), cpu_s(fox_pid), time.monotonic()
            client.pump(args.window)
            h1, f1, t1 = cpu_s(hmi_pid), cpu_s(fox_pid), time.monotonic()
            done.set()
            reader.join()
        out["hmi"] = ((h1 - h0) / (t1 - t0), rss_mb(hmi_pid), frames[0])
        out["fox"] = ((f1 - f0) / (t1 - t0), rss_mb(fox_pid), len(client.got))
        lat = []
        for topic, _ns, data, rx in client.got:
            if topic.startswith("starfish."):
                lat.append((rx - json.loads(data)["t"]) * 1000)
        out["lat"] = (statistics.median(lat), pct(lat, 0.99), len(lat))

        # 3. 1 kHz
        std(ep, "add-resource", "counter", "esair_std.drivers.sim:Counter", "-o", "rate_hz=1000",
            "--allow", "*=read")
        wait_for(lambda: client.pump(0.2) or any(t == "counter" for t, *_ in client.got),
                 timeout=30, what="the counter's channel")
        client.got.clear()
        client.pump(args.window)
        seqs = [json.loads(d)["seq"] for t, _ns, d, _rx in client.got if t == "counter"]
        distinct = set(seqs)
        out["khz"] = (max(distinct) - min(distinct) + 1 - len(distinct), len(distinct),
                      len(seqs) - len(distinct))
        client.close()
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.wait(timeout=60)
        err.close()
    load = os.getloadavg()[0]
    print(f"starfish, {args.mode} mode, windows of {args.window:g} s, load {load:.1f} "
          f"(uptime: {' '.join(f'{x:.2f}' for x in os.getloadavg())})")
    print(f"HMI process, 1 client:      CPU {out['hmi'][0] * 100:5.1f} % of a core, "
          f"RSS {out['hmi'][1]:.1f} MB ({out['hmi'][2]} frames)")
    print(f"Foxglove server, 1 client:  CPU {out['fox'][0] * 100:5.1f} % of a core, "
          f"RSS {out['fox'][1]:.1f} MB ({out['fox'][2]} messages)")
    print(f"sample -> Foxglove client:  p50 {out['lat'][0]:.1f} ms, p99 {out['lat'][1]:.1f} ms "
          f"({out['lat'][2]} samples)")
    print(f"1 kHz counter:              {out['khz'][0]} lost of {out['khz'][1]}, "
          f"{out['khz'][2]} got twice")


if __name__ == "__main__":
    main()
