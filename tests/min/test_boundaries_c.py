"""The boundary cases of tests/support/boundary_cases.py on the generated C core, built on the
host: the same absolute expectations as the Python core's (tests/min/test_boundaries.py).

The differential tests only require C == Python, so a wrong boundary made in both
cores at once passes them; these do not (docs/mutation.md, hand-made C mutants).
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from tests.support.boundary_cases import OK, READY, RX_RING, STAND, Case, all_cases, burst, events, ring_case
from esair_min.codegen import generate_robot
from esair_min.core.trace import without_marks

CASES = all_cases()


@pytest.fixture(scope="module")
def firmware(robot, tmp_path_factory) -> Path:
    """The central board's host build (gcc, warnings are errors)."""
    out = tmp_path_factory.mktemp("boundary")
    generate_robot(robot, out)
    central = out / "central"
    proc = subprocess.run(["make", "-s", "host"], cwd=central, capture_output=True,
                          text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return central / "firmware_host"


def c_run(binary: Path, case: Case) -> list[str]:
    script = binary.parent / "boundary.txt"
    script.write_text(case.text)
    proc = subprocess.run([str(binary), str(script)], capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr[-3000:]
    return events(without_marks(proc.stdout), case.ticks)


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_boundary_case_in_c(firmware, case):
    assert c_run(firmware, case) == case.expected


def test_the_ring_holds_64_bytes_in_c(firmware):
    assert c_run(firmware, ring_case(0)) == [READY, burst(STAND), OK] + [OK] * (RX_RING // 2)


def test_the_65th_byte_is_lost_and_answered_e12_in_c(firmware):
    """The lost byte is marked on the next byte that gets in (the CR sent after the
    tick): every x line that arrived whole runs, the damaged one is E12."""
    assert c_run(firmware, ring_case(1)) == \
        [READY, burst(STAND), OK] + [OK] * (RX_RING // 2) + ["E12 input overrun"]
