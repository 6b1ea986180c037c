#!/usr/bin/env bash
# Mutation testing of the Python core with mutmut (docs/mutation.md).
#
# Mutates esair_min/core/{decoder,central,player,protocol,image}.py and runs, for each
# mutant, the fast in-process tests that cover the core ([tool.mutmut] in
# pyproject.toml: test_core, test_decoder_props, test_protocol, test_image,
# test_overrun, test_boundaries, test_core_edges; no gpsim, no host C, no pty).
# Then prints the kill rate, the survivors that docs/mutation.md does not list as
# equivalent, and the listed equivalents that no longer survive.
#
# Slow (tens of minutes on a shared 2-core machine): NOT part of the test suite or CI.
#
#   bash scripts/mutation.sh                 # fresh run (removes mutants/ first)
#   MAX_CHILDREN=1 bash scripts/mutation.sh  # mutmut's parallel workers (default 2)
#   KEEP=1 bash scripts/mutation.sh          # reuse mutants/ (mutmut's own cache)
#
# mutmut works in mutants/ (a copy of the sources, git-ignored; its log is
# mutants/run.log). Exit status 0 when every surviving mutant is a listed equivalent.
set -euo pipefail
cd "$(dirname "$0")/.."
python -m pip install -q '.[test,mutation]'
if [[ -z "${KEEP:-}" ]]; then
    rm -rf mutants
fi
mkdir -p mutants
# mutmut's progress spinner goes to the log; the summary is computed below.
mutmut run --max-children "${MAX_CHILDREN:-2}" > mutants/run.log 2>&1 || {
    tail -n 40 mutants/run.log
    echo "mutmut run failed (full log: mutants/run.log)" >&2
    exit 1
}
python scripts/mutation_report.py
