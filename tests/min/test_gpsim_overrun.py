"""Receive overruns on the PIC18F452 build in gpsim, against the Python core (issue 10).

PAPA-MAN's central board at 115200 baud (conftest ``fast_robot``): 64 bytes then
arrive within one tick, so a held write lets the 64-byte ring overflow as in the
Python harness, and the two can be compared reply for reply and write for write.
Needs the toolchain (scripts/install-toolchain.sh); without it these tests FAIL.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from esair_min.codegen import generate_robot
from esair_min.core.stimulus import run_script
from esair_min.pic.build import build_board, toolchain
from esair_min.pic.gpsim_harness import GpsimSetup, compare, run_stimulus

pytestmark = pytest.mark.gpsim

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "overrun"
E12 = b"E12 input overrun\r\n"
STAND = bytes.fromhex("00" + "5A14" * 12)


@pytest.fixture(scope="module")
def fast_central(fast_robot, tmp_path_factory):
    out = tmp_path_factory.mktemp("fw_fast")
    generate_robot(fast_robot, out)
    build_board(out / "central", toolchain())
    return out / "central" / "build-pic" / "firmware.cod"


@pytest.mark.parametrize("name, e12, writes", [
    ("issue10_gpsim.txt", 1, [STAND]),
    ("gaps.txt", 4, [STAND, STAND, bytes.fromhex("00000B"), bytes.fromhex("000015"), STAND]),
])
def test_overrun_gpsim_equals_python_core(fast_robot, fast_central, tmp_path, name, e12,
                                          writes):
    stimulus = (FIXTURES / name).read_text()
    run = run_stimulus(fast_robot, stimulus, fast_central, tmp_path)
    python = run_script(fast_robot, stimulus)
    assert compare(python, run.trace(), GpsimSetup.from_robot(fast_robot)) == []
    replies = [line for _, line in run.replies]
    assert replies.count(E12) == e12
    actuator = [t for t in run.transfers if t.segments[0].address == 0x10]
    assert [t.segments[0].payload() for t in actuator] == writes
