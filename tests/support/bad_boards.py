"""Bad-board fixtures checked word for word: a folder of cases (each a copy of a bundled
robot with one change), every case with its message, refused by the validator and by
``esair check`` alike."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from esair_min.cli import main
from esair_min.errors import ConfigError
from esair_min.model.validate import load_robot


def cases(folder: Path) -> list[str]:
    """The case folders under ``folder``, sorted."""
    return sorted(p.name for p in folder.iterdir() if p.is_dir())


def assert_refused(case: Path, expected: str) -> None:
    """``case`` fails validation with ``expected``; ``esair check`` prints it, exit 1."""
    with pytest.raises(ConfigError) as exc:
        load_robot(case)
    assert str(exc.value) == expected
    result = CliRunner().invoke(main, ["check", str(case)])
    assert result.exit_code == 1
    assert result.output == f"error: {expected}\n"
