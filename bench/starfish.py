"""STARFISH emulator benchmark (issue 22): simulated seconds per wall second and per CPU
second for STARFISH driving a square, side by side with PAPA-MAN dancing (bench/
emulator.py's run) in the same process, interleaved; and the flow odometry's error
over a 4 m square against the world's true pose.

1. Speed: a host drives a 1.5 m square at 250 mm/s for --seconds simulated seconds
   (laps repeated), sending the leg's velocity and asking the odometry every 50 ms
   (2 lines every 50 ms, the watchdog fed), through the central core, the drive board,
   both flow sensors and the world. Median of --repeat runs.
2. Odometry: one 4 m square (16 m of path, 64.3 s) with the flow sensors' noise at 0,
   1, 2 and 5 % of the motion (seeded): error of the dead-reckoned pose at the end and
   the largest along the way, and the heading error at the end.

With ``--before OTHER_CHECKOUT`` (e.g. a worktree of main) the speeds of that tree are
measured too, side by side: each run is a fresh process of one tree, the two trees
alternating, so load from other jobs hits both alike.

Run: python bench/starfish.py [--seconds 60] [--repeat 3] [--before DIR]. Prints
figures; asserts nothing.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from esair_min.emulator.starfish import FlowOptions, StarfishSim, drive_square  # noqa: E402
from esair_min.model.validate import load_robot  # noqa: E402
from esair_min.world import Pose, World  # noqa: E402


def _papaman_bench():
    spec = importlib.util.spec_from_file_location("bench_emulator", ROOT / "bench" / "emulator.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def square_speed(robot, seconds: float) -> dict:
    sim = StarfishSim(robot, World(pose=Pose(1000, 1000, 0)), keep_trace=False)
    side, speed = 1500, 250
    lap_s = 4 * side / speed
    laps = max(1, round(seconds / lap_s))
    t0, c0 = time.perf_counter(), time.process_time()
    run = drive_square(sim, side, speed, laps=laps)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return {"wall": wall, "cpu": cpu, "sim": sim.now_s, "polls": run.polls,
            "contacts": sim.world.collisions}


#: One run of both robots in a fresh process of a tree (its own esair_min and bench).
CHILD = """
import importlib.util, json, sys, time
root = sys.argv[1]
sys.path.insert(0, root)
from esair_min.emulator.starfish import StarfishSim, drive_square
from esair_min.model.validate import load_robot
from esair_min.world import Pose, World
spec = importlib.util.spec_from_file_location("bench_emulator", root + "/bench/emulator.py")
pm = importlib.util.module_from_spec(spec)
spec.loader.exec_module(pm)
seconds = float(sys.argv[2])
robot = load_robot(root + "/boards/starfish")
sim = StarfishSim(robot, World(pose=Pose(1000, 1000, 0)), keep_trace=False)
laps = max(1, round(seconds / (4 * 1500 / 250)))
t0, c0 = time.perf_counter(), time.process_time()
drive_square(sim, 1500, 250, laps=laps)
sq = {"wall": time.perf_counter() - t0, "cpu": time.process_time() - c0, "sim": sim.now_s}
dance = pm.dancing(load_robot(root + "/boards/papaman"), seconds)
print(json.dumps({"square": sq, "dance": {k: dance[k] for k in ("wall", "cpu", "sim")}}))
"""


def in_process(root: Path, seconds: float) -> tuple[dict, dict]:
    """One run of both robots in a fresh Python process of the tree at ``root``."""
    env = dict(os.environ, PYTHONPATH=str(root))
    out = subprocess.run([sys.executable, "-c", CHILD, str(root), str(seconds)], cwd=root,
                         env=env, check=True, capture_output=True, text=True).stdout
    got = json.loads(out.splitlines()[-1])
    return got["square"], got["dance"]


def rate(rs: list[dict], key: str) -> float:
    return statistics.median(r["sim"] / r[key] for r in rs)


def side_by_side(before: Path, seconds: float, repeat: int) -> None:
    runs: dict[str, tuple[list[dict], list[dict]]] = {"before": ([], []), "after": ([], [])}
    for _ in range(repeat):                              # alternating: load hits both
        for name, root in (("before", before), ("after", ROOT)):
            sq, dance = in_process(root, seconds)
            runs[name][0].append(sq)
            runs[name][1].append(dance)
    print(f"Before ({before}) and after ({ROOT}), {seconds:g} simulated s per run, "
          f"median of {repeat} fresh processes each, alternating:")
    print(f"  {'':26s} {'before wall':>12s} {'after wall':>11s} {'before CPU':>11s} "
          f"{'after CPU':>10s} {'after/before (CPU)':>19s}")
    for k, label in enumerate(("STARFISH driving a square", "PAPA-MAN dancing")):
        b, a = runs["before"][k], runs["after"][k]
        print(f"  {label:26s} {rate(b, 'wall'):11.0f}x {rate(a, 'wall'):10.0f}x "
              f"{rate(b, 'cpu'):10.0f}x {rate(a, 'cpu'):9.0f}x "
              f"{rate(a, 'cpu') / rate(b, 'cpu'):18.2f}x")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--before", type=Path, default=None,
                    help="another checkout (e.g. a worktree of main): its speeds measured "
                         "too, side by side")
    args = ap.parse_args()
    if args.before is not None:
        side_by_side(args.before.resolve(), args.seconds, args.repeat)
    starfish = load_robot(ROOT / "boards" / "starfish")
    papaman = load_robot(ROOT / "boards" / "papaman")
    pm = _papaman_bench()
    sq, dance = [], []
    for _ in range(args.repeat):                         # interleaved: load hits both
        sq.append(square_speed(starfish, args.seconds))
        dance.append(pm.dancing(papaman, args.seconds))

    print(f"Emulator speed, {args.seconds:g} simulated s per run, median of {args.repeat} "
          "runs (interleaved):")
    print(f"  {'':34s} {'per wall s':>11s} {'per CPU s':>10s}")
    print(f"  {'real time (the need)':34s} {1:10.0f}x {1:9.0f}x")
    print(f"  {'goal':34s} {200:10.0f}x {200:9.0f}x")
    print(f"  {'STARFISH driving a square':34s} {rate(sq, 'wall'):10.0f}x {rate(sq, 'cpu'):9.0f}x")
    print(f"  {'PAPA-MAN dancing (bench/emulator)':34s} {rate(dance, 'wall'):10.0f}x "
          f"{rate(dance, 'cpu'):9.0f}x")
    print(f"  STARFISH / PAPA-MAN: {rate(sq, 'wall') / rate(dance, 'wall'):.2f}x wall, "
          f"{rate(sq, 'cpu') / rate(dance, 'cpu'):.2f}x CPU; margin over the goal (CPU): "
          f"{rate(sq, 'cpu') / 200:.1f}x; {sq[0]['polls']} odometry polls, "
          f"{sq[0]['contacts']} wall contacts")
    print("Flow odometry over a 4 m square (16 m of path) vs the world's true pose:")
    print(f"  {'noise':>6s} {'end error':>10s} {'max error':>10s} {'heading err':>12s}")
    for noise in (0.0, 0.01, 0.02, 0.05):
        sim = StarfishSim(starfish, World(pose=Pose(500, 500, 0)), FlowOptions(noise=noise),
                          keep_trace=False)
        run = drive_square(sim, 4000)
        dth = math.degrees(run.odometry_end[2] - run.true_end[2])
        print(f"  {noise * 100:5.0f}% {run.end_error_mm:8.1f} mm {run.max_error_mm:8.1f} mm "
              f"{dth:+10.2f} deg")


if __name__ == "__main__":
    main()
