"""Hand-made mutants made in BOTH cores at once (docs/mutation.md, "The generated C").

mutmut mutates the Python core only, and the generated C is held to the Python core by
the differential tests, which compare the two traces: a wrong boundary made in both
at once passes them. Each mutant below is one boundary made wrong the same way in the
Python core and in the C template. For each, the checkout (tracked and untracked,
not ignored files) is copied to a temporary folder, the edits are applied, and three
suites run there:

- the differential tests (tests/min/test_differential.py: Python == host C);
- the Python boundary tests (tests/min/test_boundaries.py: absolute expectations);
- the C boundary tests (tests/min/test_boundaries_c.py: the same cases on the host C).

A mutant is caught for the C when the C boundary tests fail. Slow (the differential
tests build the C twice per mutant): not part of the test suite or CI.

    python scripts/mutation_c.py            # every mutant
    python scripts/mutation_c.py NAME ...   # some (names: --list)
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PY_CENTRAL = "esair_min/core/central.py"
PY_PLAYER = "esair_min/core/player.py"
PY_DECODER = "esair_min/core/decoder.py"
PY_ENCODING = "esair_min/model/encoding.py"
C_CENTRAL = "firmware_templates/central/core/central.c.j2"

SUITES = {
    "differential": ["tests/min/test_differential.py"],
    "boundaries (Python)": ["tests/min/test_boundaries.py"],
    "boundaries (C)": ["tests/min/test_boundaries_c.py"],
}


@dataclass(frozen=True)
class Mutant:
    name: str
    what: str
    edits: tuple[tuple[str, str, str], ...]    # (file, old text, new text): old once


MUTANTS = (
    Mutant("hold-all-min", "a servo's lower limit off by one in the all-servos path "
           "(t, c): lo - 1 accepted", (
               (PY_CENTRAL,
                "for (lo, hi), angle in zip(self._limits, angles):\n"
                "            if not lo <= angle <= hi:",
                "for (lo, hi), angle in zip(self._limits, angles):\n"
                "            if not lo - 1 <= angle <= hi:"),
               (C_CENTRAL,
                "        angle_of(i);\n        if (outside(i)) {",
                "        angle_of(i);\n"
                "        if (outside(i) && num + 1u != ROM16(ES_R_LIM_MIN, i)) {"))),
    Mutant("motor-max", "a servo's upper limit off by one in o: hi + 1 accepted", (
        (PY_CENTRAL,
         "            lo, hi = self._limits[m]\n            if not lo <= angle <= hi:",
         "            lo, hi = self._limits[m]\n            if not lo <= angle <= hi + 1:"),
        (C_CENTRAL,
         "        if (outside(m)) {",
         "        if (outside(m) && num != ROM16(ES_R_LIM_MAX, m) + 1u) {"))),
    Mutant("frame-max", "a servo's upper limit off by one in stored frames: hi + 1 "
           "written", (
               (PY_PLAYER,
                "if low >= 100 or not lo <= angle <= hi:",
                "if low >= 100 or not lo <= angle <= hi + 1:"),
               (C_CENTRAL,
                "if (!decode((uint8_t)(2u * i)) || outside(i)) {",
                "if (!decode((uint8_t)(2u * i))\n"
                "            || (outside(i) && num != ROM16(ES_R_LIM_MAX, i) + 1u)) {"))),
    Mutant("frame-low-100", "a stored pair's low byte of 100 taken as an angle", (
        (PY_PLAYER, "if low >= 100 or", "if low > 100 or"),
        (C_CENTRAL, "return (uint8_t)(buf[k] < 100u);", "return (uint8_t)(buf[k] <= 100u);"))),
    Mutant("threshold-ge", "the reaction fires at the threshold (> made >=)", (
        (PY_PLAYER, "if abs(a - b) > self.threshold:", "if abs(a - b) >= self.threshold:"),
        (C_CENTRAL, "if (diff <= (int32_t)ROM16(ES_R_RE_THRESHOLD, tb_i)) {",
         "if (diff < (int32_t)ROM16(ES_R_RE_THRESHOLD, tb_i)) {"))),
    Mutant("samples-plus-one", "the reaction fires one tipping sample late", (
        (PY_PLAYER, "if self.count >= self.samples:", "if self.count > self.samples:"),
        (C_CENTRAL, "if (rc < ROM8(ES_R_RE_SAMPLES, tb_i)) {",
         "if (rc <= ROM8(ES_R_RE_SAMPLES, tb_i)) {"))),
    Mutant("speed-26", "speed letter 26 ('{') accepted by o", (
        (PY_DECODER, "not 0 <= s <= MAX_SPEED", "not 0 <= s <= MAX_SPEED + 1"),
        (C_CENTRAL, "if (m >= ES_SERVOS || spd > 25u) {",
         "if (m >= ES_SERVOS || spd > 26u) {"))),
    Mutant("line-41", "41-character lines accepted (the C gets the same constant "
           "through the generator)", (
               (PY_ENCODING, "MAX_LINE = 40\n", "MAX_LINE = 41\n"),)),
)


def copy_checkout(dest: Path) -> None:
    files = subprocess.run(["git", "ls-files", "-z", "-co", "--exclude-standard"],
                           cwd=ROOT, capture_output=True, check=True).stdout.split(b"\0")
    for name in filter(None, files):
        src = ROOT / name.decode()
        if src.is_file():
            (dest / name.decode()).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dest / name.decode())


def apply(mutant: Mutant, tree: Path) -> None:
    for file, old, new in mutant.edits:
        path = tree / file
        text = path.read_text()
        if text.count(old) != 1:
            raise SystemExit(f"{mutant.name}: {file} has {text.count(old)} copies of "
                             f"{old!r} (the code changed: update scripts/mutation_c.py)")
        path.write_text(text.replace(old, new))


def suite_fails(tree: Path, tests: list[str]) -> bool:
    proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-x", "-p", "no:cacheprovider",
                           "--hypothesis-seed=0", *tests],
                          cwd=tree, capture_output=True, text=True)
    if proc.returncode not in (0, 1):
        raise SystemExit(f"pytest could not run {tests} in {tree}:\n{proc.stdout[-3000:]}"
                         f"{proc.stderr[-3000:]}")
    return proc.returncode == 1


def run(mutant: Mutant | None) -> dict[str, bool]:
    with tempfile.TemporaryDirectory(prefix="esair-cmut-") as tmp:
        tree = Path(tmp)
        copy_checkout(tree)
        if mutant is not None:
            apply(mutant, tree)
        return {suite: suite_fails(tree, tests) for suite, tests in SUITES.items()}


def main(argv: list[str]) -> int:
    if argv == ["--list"]:
        for m in MUTANTS:
            print(f"{m.name:18} {m.what}")
        return 0
    chosen = [m for m in MUTANTS if not argv or m.name in argv]
    if argv and len(chosen) != len(set(argv)):
        print(f"unknown mutant name in {argv} (see --list)", file=sys.stderr)
        return 2
    clean = run(None)
    if any(clean.values()):
        print(f"the unmutated checkout fails: {clean}", file=sys.stderr)
        return 1
    width = max(len(s) for s in SUITES)
    print(f"{'mutant':18} " + " ".join(f"{s:>{width}}" for s in SUITES))
    survivors = 0
    for m in chosen:
        result = run(m)
        print(f"{m.name:18} " + " ".join(f"{'killed' if result[s] else 'passes':>{width}}"
                                          for s in SUITES), flush=True)
        survivors += not result["boundaries (C)"]
    print(f"{len(chosen) - survivors} of {len(chosen)} both-core mutants killed by the C "
          f"boundary tests")
    return 1 if survivors else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
