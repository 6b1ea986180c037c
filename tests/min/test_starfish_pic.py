"""STARFISH's central core compiled for the PIC18F452 (SDCC) and timed in gpsim, with a
stub hal: the core's own cycle counts and sizes, exact (the port's build:
tests/min/test_starfish_gpsim.py)."""

from __future__ import annotations

from pathlib import Path

import pytest

from esair_min.codegen import generate_robot
from esair_min.pic.build import BuildError, toolchain
from esair_min.pic.starfish_bench import measure_core

pytestmark = pytest.mark.gpsim

MAIN = Path("tests/fixtures/pic/starfish_core_bench.c")


def test_core_cycles_and_size(starfish, tmp_path):
    try:
        tc = toolchain()
    except BuildError as exc:
        pytest.fail(str(exc), pytrace=False)
    generate_robot(starfish, tmp_path / "fw")
    got = measure_core(tmp_path / "fw" / "central", MAIN, tmp_path / "pic", tc)
    assert got.kinematics == (3538, 3538, 3538)     # 0.71 ms at 20 MHz
    assert (got.rx_char, got.rx_line, got.tick) == (77, 6285, 543)
    assert (got.usage.program_bytes, got.usage.data_bytes) == (6342, 391)
