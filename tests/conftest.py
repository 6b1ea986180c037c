"""Fixtures shared by the test modules."""

from pathlib import Path

import pytest

from codegen import generate_robot
from esair_min.pic.build import BuildError, build_board, toolchain
from esair_min.model.validate import load_robot

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="session")
def robot():
    """The validated PAPA-MAN robot of boards/papaman (frozen: safe to share)."""
    return load_robot(ROOT / "boards" / "papaman")


@pytest.fixture(scope="session")
def pic_firmware(robot, tmp_path_factory):
    """PAPA-MAN's generated firmware, each board built for the PIC18F452 on first use:
    ``pic_firmware("central")`` is the board's folder (``build-pic/firmware.cod`` in
    it). Without the toolchain the test fails with the install hint."""
    try:
        tc = toolchain()
    except BuildError as exc:
        pytest.fail(str(exc), pytrace=False)
    out = tmp_path_factory.mktemp("pic")
    generate_robot(robot, out)
    built: dict[str, Path] = {}

    def board(role: str) -> Path:
        if role not in built:
            build_board(out / role, tc)
            built[role] = out / role
        return built[role]

    return board
