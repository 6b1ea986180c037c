#!/usr/bin/env bash
# Mutation testing of STD's safety rules with mutmut (docs/mutation.md, "STD").
#
# Mutates esair_std/supervisor.py, connections.py and hosts/resource_host.py (the supervisors,
# the connections, the resource host's command path and its deadlines) and runs, for
# each mutant, tests/std/test_*_rules.py (and test_resource_host_runtime.py) in thread mode; WIDE=1 with the names
# of that pass's survivors runs them again with the wider thread-mode selection of
# scripts/mutation_std.toml. mutmut reads its
# configuration from pyproject.toml only, so this works in a scratch copy of the
# checkout ($WORK, default .mutation-std/, git-ignored) whose [tool.mutmut] is replaced
# by scripts/mutation_std.toml. Then prints the summary of scripts/mutation_report.py.
#
# Slow (an hour or more on a shared 2-core machine, at nice 19 by default: NICE=N to change): NOT part of the
# test suite or CI.
#
#   bash scripts/mutation_std.sh                  # fresh run
#   MAX_CHILDREN=2 bash scripts/mutation_std.sh   # mutmut's workers (default 1)
#   KEEP=1 bash scripts/mutation_std.sh           # reuse $WORK/mutants (mutmut's cache)
#   WIDE=1 bash scripts/mutation_std.sh NAME...   # these mutants, wider tests (after a run)
#
# mutmut (3.8) resets EVERY result of its cache when the test selection changes, so a
# WIDE=1 run works in a cache of its own ($WORK-wide, default .mutation-std-wide/): the
# first pass's results in $WORK stay. Run a pass's survivors again by name (KEEP=1
# bash scripts/mutation_std.sh NAME...) after adding tests: a named mutant always reruns.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
WORK=${WORK:-$ROOT/.mutation-std}
if [[ -n "${WIDE:-}" ]]; then
    WORK=$WORK-wide
fi
python -c "import mutmut" 2>/dev/null || python -m pip install -q '.[mutation]'
if [[ -z "${KEEP:-}" && $# -eq 0 ]]; then
    rm -rf "$WORK"
fi
mkdir -p "$WORK"
# the checkout's files as they are now (tracked and new, not ignored ones)
git ls-files -z --cached --others --exclude-standard | grep -zv '^\.mutation-std' \
    | tar --null -T - -cf - | tar -xf - -C "$WORK"
python - "$WORK/pyproject.toml" scripts/mutation_std.toml "${WIDE:-}" <<'PY'
import re, sys, tomllib
path, conf, wide = sys.argv[1], open(sys.argv[2]).read(), sys.argv[3]
table, _, rest = conf.partition("\n[wide]\n")
if wide:
    sel = tomllib.loads(rest)["pytest_add_cli_args_test_selection"]
    table = re.sub(r"(?m)^pytest_add_cli_args_test_selection = .*$",
                   "pytest_add_cli_args_test_selection = " + repr(sel).replace("'", '"'), table)
text = open(path).read()
text = re.sub(r"(?ms)^\[tool\.mutmut\]\n.*?(?=^\[)", "", text)
open(path, "w").write(text + "\n" + table)
PY
cd "$WORK"
mkdir -p mutants
nice -n "${NICE:-19}" mutmut run --max-children "${MAX_CHILDREN:-1}" "$@" > mutants/run.log 2>&1 || {
    tail -n 40 mutants/run.log
    echo "mutmut run failed (full log: $WORK/mutants/run.log)" >&2
    exit 1
}
python "$ROOT/scripts/mutation_report.py" --root "$WORK" --doc "$ROOT/docs/mutation.md"
