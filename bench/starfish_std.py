"""STARFISH under STD: the system's figures (issue 23 item 5), on the real MIN link (the
emulated boards, started by the driver) in the example's room.

1. sound onset -> picture taken, thread and process mode side by side: the source is
   switched on (``configure starfish.mics source``) and the time to the picture's own
   time stamp is measured; beside it, the shot's floor (bench/toolkit/starfish.py: the
   turn's time-optimal profile within the board files' limits + one odometry frame + the
   camera's time; sources at random: bench/starfish_shot.py). Goal <= 2 s.
2. the robot side's memory and CPU while patrolling, process mode (``esair std run
   starfish --mode process`` in a child process): RSS of the runtime and of the driver,
   patrol and reconnect processes (the robot's), and of localize and turn_and_shoot
   (the remote center's, here on the same computer), CPU over a window as a share of one
   core. Goal: the robot side <= 250 MB RSS in all and <= 50 % of one core. The driver
   here also renders the audio and the pictures (simulation work a real robot's driver
   does not do); it is shown apart.

3. link lost -> the robot heading back (the first odometry step toward the access point
   after the radio's cut; goal <= lease + 0.5 s = 2.5 s) and out of range -> link back,
   beside the straight-line drive time from the cut to where it healed.

    python bench/starfish_std.py [--shots 4] [--trips 3] [--window 10] [--only onset|link|load]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from esair_std import Runtime  # noqa: E402
from bench.toolkit import free_endpoint, processes  # noqa: E402
from bench.toolkit.starfish import SOURCES, deployment, shot_floor  # noqa: E402
from esair_std.deploy import load_deployment  # noqa: E402

BENCH = Path(__file__).resolve().parent

def wait(fn, timeout: float):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        v = fn()
        if v:
            return v
        time.sleep(0.05)
    return None


def onset_to_picture(mode: str, shots: int) -> list[tuple[float, float]]:
    out = []
    with tempfile.TemporaryDirectory() as store, \
            Runtime(dep := deployment(store), mode=mode, endpoint=free_endpoint()) as rt:
        hz = float(dep["resources"]["starfish"].get("odometry_hz", 10))
        wait(lambda: rt.get("patrol")["reached"] >= 1, 60)
        for k in range(shots):
            x, y = SOURCES[k % len(SOURCES)]
            before = rt.get("turn_and_shoot")["shots"]
            t0 = time.time()
            rt.configure("starfish.mics", "source", {"x": x, "y": y, "on": True})
            got = wait(lambda b=before: (lambda r: r if r["shots"] > b else None)(
                rt.get("turn_and_shoot")), 30)
            rt.configure("starfish.mics", "source", {"x": x, "y": y, "on": False})
            if not got:
                print(f"  {mode}: shot {k + 1}: no picture within 30 s")
                continue
            out.append((got["last"]["t"] - t0, shot_floor(got["last"], hz)))
            time.sleep(1.0)                   # the cooldown, and patrol drives again
    return out


def link_trips(mode: str, trips: int) -> list[dict]:
    """Out of range and back, ``trips`` times: patrol heads for (4.8, 3.2), beyond the
    radio's 3 m; reconnect drives back; patrol goes on to (2.5, 3.2), then out again."""
    dep = deployment(tempfile.gettempdir())
    dep["resources"]["starfish"]["pose"] = [2.5, 3.2, 0.0]
    dep["behaviors"]["patrol"]["waypoints"] = [[4.8, 3.2], [2.5, 3.2]]
    dep["behaviors"]["tracker"] = {"class": "starfish_comps:Tracker", "deadline": 5, "uses": {
        "starfish.radio": "read", "starfish.odometry": "read"}}
    with Runtime(load_deployment(dep, base_dir=BENCH), mode=mode, endpoint=free_endpoint()) as rt:
        done = wait(lambda: (lambda t: t if len(t) >= trips and t[trips - 1]["heal"] else None)(
            rt.get("tracker")), 40 * trips)
        if not done:
            print(f"  {mode}: tracker {rt.get('tracker')}; "
                  f"{[(c['name'], c['state'], c.get('reason')) for c in rt.ls()]}")
    return (done or [])[:trips]


def proc_stat(pid: int) -> tuple[float, float]:
    """(RSS MB, CPU seconds) of one process."""
    with open(f"/proc/{pid}/status") as f:
        rss = next(int(line.split()[1]) for line in f if line.startswith("VmRSS:")) / 1024
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return rss, (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def children(pid: int) -> dict[str, int]:
    """name -> pid of the runtime's agent processes (from their --spec)."""
    out = {}
    for child, ppid, cmdline in processes():
        cmd = cmdline.split(b"\0")
        if ppid == pid and b"--spec" in cmd:
            out[json.loads(cmd[cmd.index(b"--spec") + 1])["name"]] = child
    return out


def robot_load(window: float) -> None:
    ep = free_endpoint()
    with tempfile.TemporaryDirectory() as cwd:
        run = subprocess.Popen([sys.executable, "-m", "esair_min.cli", "std", "run", "starfish",
                                "--mode", "process", "--no-top", "-e", ep], cwd=cwd,
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                               env=dict(os.environ, PYTHONPATH=str(ROOT)))
        try:
            assert run.stdout is not None
            run.stdout.readline()
            names = ("starfish", "patrol", "reconnect", "localize", "turn_and_shoot")
            kids = wait(lambda: (lambda c: c if all(n in c for n in names) else None)(children(run.pid)), 90)
            if not kids:
                print("  the components did not all start within 90 s")
                return
            time.sleep(3.0)                           # patrolling
            pids = {"runtime": run.pid, **{n: kids[n] for n in names}}
            first = {n: proc_stat(p) for n, p in pids.items()}
            t0 = time.monotonic()
            time.sleep(window)
            dt = time.monotonic() - t0
            last = {n: proc_stat(p) for n, p in pids.items()}
        finally:
            run.terminate()
            run.wait(30)
    print(f"{'process':>16} | {'side':>6} | {'RSS MB':>7} | {'CPU % of one core':>17}")
    tot = {"robot": [0.0, 0.0], "remote": [0.0, 0.0]}
    for n in pids:
        side = "remote" if n in ("localize", "turn_and_shoot") else "robot"
        cpu = 100 * (last[n][1] - first[n][1]) / dt
        tot[side][0] += last[n][0]
        tot[side][1] += cpu
        print(f"{n:>16} | {side:>6} | {last[n][0]:>7.1f} | {cpu:>17.1f}")
    rss, cpu = tot["robot"]
    drv_cpu = 100 * (last["starfish"][1] - first["starfish"][1]) / dt
    print(f"robot side: {rss:.1f} MB RSS ({rss / 250:.2f}x the 250 MB goal), {cpu:.1f} % of one core "
          f"({cpu / 50:.2f}x the 50 % goal; without the driver's simulation {cpu - drv_cpu:.1f} %)")
    print(f"remote side: {tot['remote'][0]:.1f} MB RSS, {tot['remote'][1]:.1f} % of one core")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shots", type=int, default=4)
    ap.add_argument("--window", type=float, default=10.0)
    ap.add_argument("--trips", type=int, default=3)
    ap.add_argument("--only", choices=["onset", "link", "load"], default=None, help="one figure only")
    args = ap.parse_args()
    print(f"load average {os.getloadavg()[0]:.1f}")
    if args.only in (None, "onset"):
        onset(args.shots)
    if args.only in (None, "link"):
        link(args.trips)
    if args.only in (None, "load"):
        print(f"3. robot side while patrolling, process mode, over {args.window:g} s")
        robot_load(args.window)


def onset(shots: int) -> None:
    print("1. sound onset -> picture taken (goal <= 2 s), beside the shot's floor (its "
          "turn's profile + an odometry frame + the camera)")
    for mode in ("thread", "process"):
        res = onset_to_picture(mode, shots)
        if res:
            lat = sorted(r[0] for r in res)
            print(f"  {mode:>7}: " + ", ".join(f"{a:.2f} s (floor {b:.2f} s)" for a, b in res)
                  + f"; median {lat[len(lat) // 2]:.2f} s = {lat[len(lat) // 2] / 2.0:.2f}x goal, "
                    f"max {lat[-1]:.2f} s")


def link(n: int) -> None:
    speed = 0.25   # m/s: reconnect's speed
    print("2. link lost -> robot heading back (goal <= lease 2 s + 0.5 s); out of range -> link back, "
          "beside the straight-line drive from the cut to where it healed at 0.25 m/s")
    for mode in ("thread", "process"):
        trips = link_trips(mode, n)
        for t in trips:
            back = t["back"] - t["cut"] if t["back"] else float("nan")
            straight = math.dist(t["cut_xy"], t["heal_xy"]) / speed if t["cut_xy"] and t["heal_xy"] else 0
            print(f"  {mode:>7}: heading back {back:.2f} s ({back / 2.5:.2f}x goal); link back after "
                  f"{t['heal'] - t['cut']:.2f} s, straight line {straight:.2f} s "
                  f"({(t['heal'] - t['cut']) / max(straight, 1e-9):.2f}x)")
        if len(trips) < n:
            print(f"  {mode:>7}: only {len(trips)} of {n} trips completed")


if __name__ == "__main__":
    main()
