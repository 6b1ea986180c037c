"""Throughput of the host-built C decoder as a multiple of the Python decoder's, on
the same input, in one run.

    python bench/decoder_c_vs_python.py [LINES]

Generates PAPA-MAN's central firmware, builds ./firmware_host (gcc -O2), writes one
stimulus script of LINES command lines (every kind of command, invalid and garbage
lines, checksums, ticks between), then runs it through the C firmware and through the
Python harness (esair_min.core.stimulus.run_script). Prints received bytes per second for
each and the ratio, after checking that both traces are identical.
"""

from __future__ import annotations

import random
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from esair_min.codegen import generate_robot  # noqa: E402
from esair_min.core.stimulus import run_script, unescape  # noqa: E402
from esair_min.core.protocol import add_checksum  # noqa: E402
from esair_min.model.validate import load_robot  # noqa: E402


def esc(data: bytes) -> str:
    return "".join(chr(b) if chr(b).isalnum() and b < 0x80 else f"\\x{b:02X}" for b in data)


def make_script(lines: int, rng: random.Random) -> str:
    out = ["boot"]
    for _ in range(lines):
        r = rng.random()
        if r < 0.25:
            line = "a" + "".join(f"{rng.randint(0, 25):03d}" for _ in range(12))
        elif r < 0.4:
            line = rng.choice(["v", "x", "s", "PLY09", "q", "zzz", "PLY3"])
        elif r < 0.5:
            line = "c" + "".join(rng.choice("0Ul.A") for _ in range(12))
        elif r < 0.6:
            line = f"o{rng.choice('abcl')}c{rng.randint(0, 200):03d}"
        elif r < 0.7:
            line = "x" * rng.randint(41, 60)
        else:
            line = rng.choice(["v", "a" + "002" * 12, "x"])
        if rng.random() < 0.3:
            line = add_checksum(line)
        out.append("rx " + esc(line.encode() + b"\r\n"))
        if line[0] in "co":
            out.append("tick")
    return "\n".join(out) + "\n"


def main() -> None:
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 20000
    robot = load_robot(ROOT / "boards" / "papaman")
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp)
        generate_robot(robot, base)
        central = base / "central"
        subprocess.run(["make", "-s", "host"], cwd=central, check=True)
        script = make_script(n, random.Random(1))
        path = central / "bench.txt"
        path.write_text(script)
        rx_bytes = sum(len(unescape(line[3:])) for line in script.splitlines()
                       if line.startswith("rx "))
        t0 = time.perf_counter()
        proc = subprocess.run([str(central / "firmware_host"), str(path)],
                              capture_output=True, text=True, check=True)
        c_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        py_lines = run_script(robot, script, str(path))
        py_s = time.perf_counter() - t0
    same = proc.stdout.splitlines() == py_lines
    print(f"{n} command lines, {rx_bytes} bytes received, {len(py_lines)} trace lines "
          f"(C and Python traces {'identical' if same else 'DIFFER'})")
    print(f"  C (host build, process included)  {rx_bytes / c_s:12.0f} bytes/s  ({c_s * 1e3:.1f} ms)")
    print(f"  Python core (harness)             {rx_bytes / py_s:12.0f} bytes/s  ({py_s * 1e3:.1f} ms)")
    print(f"  ratio C/Python  {py_s / c_s:.1f}x")


if __name__ == "__main__":
    main()
