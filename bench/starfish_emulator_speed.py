"""STARFISH emulator benchmark (issue 22): simulated seconds per wall second and per CPU
second for STARFISH driving a square, side by side with PAPA-MAN dancing (bench/
emulator_speed.py's run) in the same process, interleaved; and the flow odometry's error
over a 4 m square against the world's true pose.

1. Speed: a host drives a 1.5 m square at 250 mm/s for --seconds simulated seconds
   (laps repeated), sending the leg's velocity and asking the odometry every 50 ms
   (2 lines every 50 ms, the watchdog fed), through the central core, the drive board,
   both flow sensors and the world. Median of --repeat runs.
   The floor (:func:`floor_loop`): the same arithmetic per simulated second in one
   function on locals, no events and no objects: what pure Python cannot go below at
   this fidelity; run right after each repeat's square, the emulator's rate over it
   (a figure that moves less with this machine's speed than either rate) is printed.
2. Odometry: one 4 m square (16 m of path, 64.3 s) with the flow sensors' noise at 0,
   1, 2 and 5 % of the motion (seeded): error of the dead-reckoned pose at the end and
   the largest along the way, and the heading error at the end.

With ``--before OTHER_CHECKOUT`` (e.g. a worktree of main) the speeds of that tree are
measured too, side by side: each run is a fresh process of one tree, the two trees
alternating, so load from other jobs hits both alike.

Run: python bench/starfish_emulator_speed.py [--seconds 60] [--repeat 3] [--before DIR]. Prints
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

from esair_min.emulator.starfish.robot_sim import FlowOptions, StarfishSim, drive_square  # noqa: E402
from esair_min.model.validate import load_robot  # noqa: E402
from esair_min.world import Pose, World  # noqa: E402


def _papaman_bench():
    spec = importlib.util.spec_from_file_location("bench_emulator", ROOT / "bench" / "emulator_speed.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def floor_loop(seconds: float) -> dict:
    """The floor: the arithmetic a STARFISH emulation at this fidelity cannot skip, per
    simulated second of the square, in one Python function on locals (no events, no
    objects, no checks): per central tick (100 a second) two stretches of three wheels'
    travel, the body velocity, the pose (cos, sin, the wall clearance's hypot) and two
    flow sensors (frame, hypot, the speed check, one gaussian pair each, the reads and
    their sums); 20 more world steps a second (the host's 50 ms periods end between
    ticks); per 50 ms the two lines' bytes decoded (V: fields, kinematics, the drive
    write packed; O: the 37-byte reply formatted) and the replies split by the host."""
    import random
    import re
    import struct
    fields = re.compile(rb"V([+-][0-9]{4})([+-][0-9]{4})([+-][0-9]{4})").fullmatch
    pack = struct.Struct("<B3H").pack
    rng = [random.Random(1), random.Random(2)]
    cos, sin, hypot, log, sqrt = math.cos, math.sin, math.hypot, math.log, math.sqrt
    inv = (0.0, -0.57735, 0.57735, 0.6667, -0.3333, -0.3333, 3.3333, 3.3333, 3.3333)
    frames = ((60.0, 0.0, 1.0, 0.0), (-60.0, 0.0, 0.0, 1.0))
    r0, r1, r2 = 0.0, -216.5, 216.5
    x = y = th = 1000.0
    acc = [[0.0, 0.0], [0.0, 0.0]]
    sums = [[0, 0, 0], [0, 0, 0]]
    line_v, line_o = b"V+0250+0000+0000\r\n", b"O\r\n"
    buf = bytearray(40)
    steps = round(seconds * 100)
    c0 = time.process_time()
    for n in range(steps):
        moves = 2 if n % 5 == 0 else 1
        for _ in range(moves):                           # world steps (+ a period's end)
            dt = 0.0
            t0 = t1 = t2 = 0.0
            for seg in (0.004, 0.006):                   # the drive tick splits the travel
                dt += seg
                t0 += r0 * seg
                t1 += r1 * seg
                t2 += r2 * seg
            s0, s1, s2 = t0 / dt, t1 / dt, t2 / dt
            a, b, c, d, e, f, g, h, i = inv
            vx, vy, om = a * s0 + b * s1 + c * s2, d * s0 + e * s1 + f * s2, g * s0 + h * s1 + i * s2
            mid = th + om * dt / 2
            cm, sm = cos(mid), sin(mid)
            nx, ny = x + (cm * vx - sm * vy) * dt, y + (sm * vx + cm * vy) * dt
            if hypot(nx - x, ny - y) < 1e9:
                x, y, th = nx, ny, th + om * dt
            for k, (px, py, cf, sf) in enumerate(frames):
                ux, uy = (vx - om * py) * dt, (vy + om * px) * dt
                dx, dy = cf * ux + sf * uy, -sf * ux + cf * uy
                dist = hypot(dx, dy)
                if dist / 25.4 / dt > 12.0:
                    continue
                rnd = rng[k].random
                x2pi = rnd() * 6.283185307179586
                g2 = sqrt(-2.0 * log(1.0 - rnd()))
                a_ = acc[k]
                a_[0] += (dx + cos(x2pi) * g2 * 0.02 * abs(dx)) * 15.748
                a_[1] += (dy + sin(x2pi) * g2 * 0.02 * abs(dy)) * 15.748
        for k in (0, 1):                                 # the central tick's reads
            a_, s_ = acc[k], sums[k]
            ry, rx = int(a_[1]), int(a_[0])
            ry = -128 if ry < -128 else 127 if ry > 127 else ry
            rx = -128 if rx < -128 else 127 if rx > 127 else rx
            a_[1] -= ry
            a_[0] -= rx
            s_[0] = (s_[0] + rx) & 0xFFFFFFFF
            s_[1] = (s_[1] + ry) & 0xFFFFFFFF
        if n % 5 == 0:                                   # a 50 ms period's two lines
            buf[:16] = line_v[:16]
            m = fields(bytes(buf[:16]))
            if m is not None:
                wx, wy, ww = (int(v) for v in m.groups())
                sp = [(-9459 * wx + 5461 * wy + 4915 * ww + 8192) >> 14,
                      (9459 * wx + 5461 * wy + 4915 * ww + 8192) >> 14,
                      (0 * wx - 16384 * wy + 4915 * ww + 8192) >> 14]
                pack(0, *[v & 0xFFFF for v in sp])
            buf[:1] = line_o[:1]
            reply = (f"OK n={n & 0xFFFF} a={sums[0][0]},{sums[0][1]},90 "
                     f"b={sums[1][0]},{sums[1][1]},90\r\n").encode()
            reply.decode("latin-1").split()
    return {"cpu": time.process_time() - c0, "sim": steps / 100}


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
try:                                    # a tree from before the emulator's robot folders
    from esair_min.emulator.starfish.robot_sim import StarfishSim, drive_square
except ImportError:
    from esair_min.emulator.starfish import StarfishSim, drive_square
from esair_min.model.validate import load_robot
from esair_min.world import Pose, World
import os.path
papaman_bench = root + "/bench/emulator_speed.py"
if not os.path.exists(papaman_bench):
    papaman_bench = root + "/bench/emulator.py"
spec = importlib.util.spec_from_file_location("bench_emulator", papaman_bench)
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
    sq, dance, fl = [], [], []
    for _ in range(args.repeat):                         # interleaved: load hits all three
        sq.append(square_speed(starfish, args.seconds))
        dance.append(pm.dancing(papaman, args.seconds))
        fl.append(floor_loop(args.seconds))

    print(f"Emulator speed, {args.seconds:g} simulated s per run, median of {args.repeat} "
          "runs (interleaved):")
    print(f"  {'':34s} {'per wall s':>11s} {'per CPU s':>10s}")
    print(f"  {'real time (the need)':34s} {1:10.0f}x {1:9.0f}x")
    print(f"  {'goal':34s} {200:10.0f}x {200:9.0f}x")
    print(f"  {'STARFISH driving a square':34s} {rate(sq, 'wall'):10.0f}x {rate(sq, 'cpu'):9.0f}x")
    print(f"  {'PAPA-MAN dancing (bench/emulator_speed)':34s} {rate(dance, 'wall'):10.0f}x "
          f"{rate(dance, 'cpu'):9.0f}x")
    print(f"  {'the floor (one function on locals)':34s} {'':>11s} {rate(fl, 'cpu'):9.0f}x")
    ratios = sorted((s["sim"] / s["cpu"]) / (f["sim"] / f["cpu"]) for s, f in zip(sq, fl, strict=True))
    print(f"  STARFISH / the floor (CPU, each repeat's pair run one after the other): median "
          f"{statistics.median(ratios):.2f}x, {ratios[0]:.2f}x-{ratios[-1]:.2f}x")
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
