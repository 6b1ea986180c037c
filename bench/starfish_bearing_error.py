"""STARFISH: sound-source bearing error of `localize` (GCC-PHAT over the 4 microphones'
6 pairs, esair_std/drivers/starfish/gccphat.py) against the room's true bearing, at SNR
20 / 10 / 0 dB, with the plain cross-correlation (no phase transform) side by side as
the baseline, on the same rendered frames.

Each trial puts the robot at a random pose in the room's left half (x 0.4-2.6 m,
y 0.4-3.6 m, any heading) and the source at a random place in the right half, renders
two frames of the microphone array (the first fills the source's history at that pose)
and localizes the second. The walls echo the source (first-order image sources, gain
``--echo``, 0.5 by default): a room's reverberation, where the phase transform matters.
Goal (issue 23): median <= 5 deg, p90 <= 10 deg at 10 dB.

    python bench/starfish_bearing_error.py [--trials 200] [--seed 1]
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from esair_std.drivers.starfish.gccphat import Localizer  # noqa: E402
from esair_std.drivers.starfish.mics import DEFAULT_MICS, FRAME, RATE, AudioRenderer  # noqa: E402
from esair_std.drivers.starfish.scene import bearing_to, load_scene, wrap  # noqa: E402

GOAL_MEDIAN, GOAL_P90 = 5.0, 10.0


def run(snr: float, trials: int, seed: int, echo: float) -> dict:
    room = load_scene(ROOT / "esair_std" / "examples" / "starfish" / "room.yaml")
    room.source.x, room.source.y, room.source.on = 4.5, 3.0, True
    renderer = AudioRenderer(room, snr_db=snr, seed=seed, reflection_gain=echo)
    phat, plain = Localizer(DEFAULT_MICS, RATE), Localizer(DEFAULT_MICS, RATE, phat=False)
    rng = np.random.default_rng(seed)
    err = {"phat": [], "plain": []}
    conf = []
    spent = 0.0
    for _ in range(trials):
        room.source.x, room.source.y = rng.uniform(3.4, 5.6), rng.uniform(0.4, 3.6)
        pose = (rng.uniform(0.4, 2.6), rng.uniform(0.4, 3.6), rng.uniform(-math.pi, math.pi))
        renderer.render(pose)
        pcm = renderer.render(pose).astype(float) / 32768
        truth = bearing_to(pose, room.source.x, room.source.y)
        t0 = time.perf_counter()
        b, c = phat.locate(pcm)
        spent += time.perf_counter() - t0
        err["phat"].append(abs(math.degrees(wrap(b - truth))))
        conf.append(c)
        err["plain"].append(abs(math.degrees(wrap(plain.locate(pcm)[0] - truth))))
    return {k: (float(np.median(v)), float(np.percentile(v, 90))) for k, v in err.items()} | {
        "conf": float(np.median(conf)), "ms": 1000 * spent / trials, "clipped": renderer.clipped}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=200)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--echo", type=float, default=0.5,
                    help="first-order wall echoes' gain (0: the direct path only)")
    args = ap.parse_args()
    frame_ms = 1000 * FRAME / RATE
    print(f"localization error vs the true bearing, {args.trials} poses per SNR "
          f"(frames of {FRAME} samples = {frame_ms:.0f} ms at {RATE} Hz, 4 microphones, "
          f"wall echoes at gain {args.echo})")
    print(f"{'SNR':>6} | {'GCC-PHAT median':>15} {'p90':>6} | {'plain CC median':>15} {'p90':>6} | "
          f"{'PHAT/plain p90':>14} | {'confidence':>10} | {'ms/frame':>8} | goal")
    for snr in (20, 10, 0):
        r = run(snr, args.trials, args.seed, args.echo)
        (m, p), (bm, bp) = r["phat"], r["plain"]
        goal = ""
        if snr == 10:
            goal = (f"median {m / GOAL_MEDIAN:.2f}x goal, p90 {p / GOAL_P90:.2f}x goal: "
                    f"{'met' if m <= GOAL_MEDIAN and p <= GOAL_P90 else 'MISSED'}")
        print(f"{snr:>4}dB | {m:>13.2f}deg {p:>5.2f} | {bm:>13.2f}deg {bp:>5.2f} | "
              f"{p / max(bp, 1e-9):>14.2f} | {r['conf']:>10.2f} | {r['ms']:>8.1f} | {goal}")
    print(f"(localizing one frame costs ms/frame of the {frame_ms:.0f} ms it covers; "
          "clipped samples: none expected)")


if __name__ == "__main__":
    main()
