"""Fixtures shared by the test modules."""

from pathlib import Path

import pytest

from esair_min.validate import load_robot

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="session")
def robot():
    """The validated PAPA-MAN robot of boards/papaman (frozen: safe to share)."""
    return load_robot(ROOT / "boards" / "papaman")
