"""Time to generate all PAPA-MAN boards (median of N runs) and ratios against baselines.

    python bench/codegen_time.py [N]

cold  : generate into an empty folder (every file written)
warm  : generate again into the same folder (write-if-changed: nothing written)
force : render and write every file without the content check (the baseline the
        write-if-changed check is compared with)
render: render only, nothing written
Prints milliseconds and ratios measured in this one run; asserts nothing about time.
"""

from __future__ import annotations

import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from esair_min.codegen import generate_robot, render_robot  # noqa: E402
from esair_min.model.validate import load_robot  # noqa: E402


def median_ms(fn, n: int) -> float:
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        times.append((time.perf_counter() - t0) * 1e3)
    return statistics.median(times)


def main() -> None:
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 15
    robot = load_robot(ROOT / "boards" / "papaman")
    render_robot(robot)                      # load templates once (as any later run)
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp)
        counter = iter(range(10**6))
        cold = median_ms(lambda: generate_robot(robot, base / f"cold{next(counter)}"), n)
        warm_dir = base / "warm"
        generate_robot(robot, warm_dir)
        warm = median_ms(lambda: generate_robot(robot, warm_dir), n)
        force = median_ms(lambda: generate_robot(robot, warm_dir, check=False), n)
        render = median_ms(lambda: render_robot(robot), n)
    files = len(render_robot(robot))
    print(f"PAPA-MAN: 3 boards, {files} files, median of {n} runs")
    print(f"  render only              {render:8.2f} ms")
    print(f"  cold generate (empty dir) {cold:7.2f} ms")
    print(f"  warm generate (unchanged) {warm:7.2f} ms")
    print(f"  forced write (no check)   {force:7.2f} ms")
    print(f"  ratio warm/cold  {warm / cold:.2f}")
    print(f"  ratio warm/forced-write  {warm / force:.2f}")


if __name__ == "__main__":
    main()
