"""The summary of a mutmut run (scripts/mutation.sh): kill rates, and the survivors
checked against the equivalent mutants listed in docs/mutation.md.

An equivalent mutant is listed as a table row of docs/mutation.md whose first cell is
the mutant's name in backticks and whose second cell is the mutated line in backticks
(``|`` written ``\\|``): a row only counts when mutmut's diff of that mutant shows this
line, so a list left stale by a code change is reported rather than trusted.

    python scripts/mutation_report.py     # after mutmut run, from the checkout's root
    python scripts/mutation_report.py --root .mutation-std   # scripts/mutation_std.sh's run

Only the listed equivalents of the modules this run mutated are checked (docs/mutation.md
lists both MIN's core and STD's).
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent      # where mutmut ran (--root)
DOC = ROOT / "docs" / "mutation.md"                # the list of equivalents (--doc)
ROW = re.compile(r"^\|\s*`([^`]+__mutmut_\d+)`\s*\|\s*`((?:[^`\\]|\\.)*)`\s*\|")


def listed_equivalents() -> dict[str, str]:
    """Mutant name -> the mutated line (stripped), from docs/mutation.md."""
    out = {}
    for line in DOC.read_text().splitlines():
        m = ROW.match(line)
        if m:
            out[m.group(1)] = m.group(2).replace("\\|", "|").strip()
    return out


def mutmut(*args: str) -> str:
    return subprocess.run(["mutmut", *args], cwd=ROOT, capture_output=True, text=True,
                          check=True).stdout


def diff_of(name: str) -> str:
    """mutmut's diff of mutant ``name`` (what ``mutmut show`` prints), computed in this
    process: one ``mutmut show`` per survivor costs seconds each."""
    try:
        from mutmut.mutation.diff_apply import get_diff_for_mutant   # mutmut 3.8 (pinned)
    except ImportError:
        return mutmut("show", name)
    os.chdir(ROOT)
    return get_diff_for_mutant(name)


def added_lines(name: str) -> list[str]:
    """The lines mutant ``name`` adds (its diff's ``+`` lines, stripped)."""
    return [ln[1:].strip() for ln in diff_of(name).splitlines()
            if ln.startswith("+") and not ln.startswith("+++")]


def module_of(name: str) -> str:
    """``esair_std.supervisor`` of ``esair_std.supervisor.xǁSupervisorǁ_fail__mutmut_3``."""
    return re.split(r"\.x[_ǁ]", name, maxsplit=1)[0]


def main(argv: list[str]) -> int:
    global ROOT, DOC
    for flag, value in zip(argv[::2], argv[1::2]):
        if flag == "--root":
            ROOT = Path(value).resolve()
        elif flag == "--doc":
            DOC = Path(value).resolve()
    mutmut("export-cicd-stats")
    stats = json.loads((ROOT / "mutants" / "mutmut-cicd-stats.json").read_text())
    status = {}
    for line in mutmut("results", "--all", "true").splitlines():
        name, _, state = line.strip().rpartition(": ")
        if name:
            status[name] = state
    modules = {module_of(n) for n in status}
    equivalents = {n: line for n, line in listed_equivalents().items() if module_of(n) in modules}
    alive = sorted(n for n, s in status.items() if s not in ("killed", "timeout", "skipped"))
    confirmed, unlisted, stale = [], [], []
    for name in alive:
        wanted = equivalents.get(name)
        if wanted is not None and wanted in added_lines(name):
            confirmed.append(name)
        else:
            unlisted.append(name)
    for name, wanted in equivalents.items():
        if name not in confirmed:
            stale.append((name, wanted, status.get(name, "no such mutant")))

    killed = stats["killed"] + stats["timeout"]
    tested = stats["total"] - stats["skipped"]
    print(f"mutants: {stats['total']} ({stats['skipped']} skipped), killed {killed} "
          f"(timeouts {stats['timeout']}), survived {stats['survived']}, "
          f"no tests {stats['no_tests']}, suspicious {stats['suspicious']}")
    print(f"kill rate: {killed}/{tested} = {100 * killed / tested:.1f} %")
    real = tested - len(confirmed)
    print(f"equivalent (docs/mutation.md): {len(confirmed)}")
    print(f"non-equivalent kill rate: {killed}/{real} = {100 * killed / real:.1f} %")
    for name in unlisted:
        print(f"\nnot killed, not a listed equivalent: {name} ({status[name]})")
        print(diff_of(name).rstrip())
    for name, wanted, state in stale:
        print(f"\nstale entry in docs/mutation.md: {name} `{wanted}` ({state})")
    return 1 if unlisted or stale else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
