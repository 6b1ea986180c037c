"""The user's first commands: `esair check`, `esair schema`, `esair --help`."""

from __future__ import annotations

import json
import re
from pathlib import Path

import click
import jsonschema
import pytest
import yaml
from click.testing import CliRunner

from esair_min.cli import main

ROOT = Path(__file__).resolve().parents[2]
PAPAMAN = ROOT / "boards" / "papaman"

SUMMARY = """\
robot 'papaman': 3 boards (actuator [actuator], central [central], sensor [sensor])
  servos: 12, sensors: 8, commands: 15, motions: 5 (stand, sit, prostrate, dance, balance), reactions: 1
  EEPROM 'motion_store': 1070 of 32768 bytes used (3.3 %)
  tick: 8.9856 ms (Timer2 prescale 16, PR2 233, postscale 12 at 20000000 Hz)
  UART: 9600 baud, SPBRG 129 BRGH=1, error +0.16 %
  I2C: 100000 Hz, SSPADD 49
  bus per frame: write 236 + next frame read 255 + sensor poll 174 bit times = 6.65 ms, 74% of a tick on the wire (the PIC master needs 1.15x that)
ok
"""


@pytest.fixture(autouse=True)
def _at_repo_root(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(ROOT)


def test_check_papaman_prints_the_summary() -> None:
    result = CliRunner().invoke(main, ["check", "boards/papaman"])
    assert result.exit_code == 0, result.output
    assert result.stderr == ""
    assert result.stdout == SUMMARY


def test_check_bundled_example_by_name(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)       # no ./papaman here: the bundled example is used
    result = CliRunner().invoke(main, ["check", "papaman"])
    assert result.exit_code == 0, result.output
    assert result.stdout == SUMMARY


def _schema() -> dict:
    result = CliRunner().invoke(main, ["schema"])
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout)


def test_schema_is_valid_json_schema() -> None:
    schema = _schema()
    jsonschema.Draft202012Validator.check_schema(schema)
    assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    assert schema["title"] == "ESAIR MIN board file"
    assert schema["additionalProperties"] is False
    assert set(schema["required"]) == {"board", "role", "i2c"}
    for name in ("Servo", "Sensor", "Motion", "Frame", "Command", "Reaction",
                 "EepromDevice", "BoardDevice"):
        assert name in schema["$defs"]


@pytest.mark.parametrize("board", ["central", "actuator", "sensor"])
def test_papaman_files_satisfy_the_schema(board: str) -> None:
    data = yaml.safe_load((PAPAMAN / f"{board}.yaml").read_text())
    jsonschema.Draft202012Validator(_schema()).validate(data)


@pytest.mark.parametrize("change, path", [
    (lambda d: d.update(uartt={"baud": 9600}), []),
    (lambda d: d["servos"][0].update(pin="RX9"), ["servos", 0, "pin"]),
    (lambda d: d["servos"][0].pop("min_angle"), ["servos", 0]),
    (lambda d: d["i2c"].update(speed_hz=200_000), ["i2c", "speed_hz"]),
])
def test_schema_rejects_what_the_model_rejects(change, path) -> None:
    data = yaml.safe_load((PAPAMAN / "actuator.yaml").read_text())
    change(data)
    errors = list(jsonschema.Draft202012Validator(_schema()).iter_errors(data))
    assert errors and list(errors[0].absolute_path) == path


def test_help_lists_every_command_with_one_line() -> None:
    result = CliRunner().invoke(main, ["--help"])
    assert result.exit_code == 0
    listing = result.stdout.split("Commands:\n", 1)[1]
    assert "check" in main.commands and "schema" in main.commands
    for name, command in main.commands.items():
        assert isinstance(command, click.Command)
        first = command.get_short_help_str(limit=1000)
        assert first, f"command {name} has no help"
        line = re.search(rf"^  {re.escape(name)}\s+(.+)$", listing, re.MULTILINE)
        assert line, f"command {name} missing from --help"
        shown = line.group(1).strip().removesuffix("...")   # click shortens to the width
        assert len(shown) >= 10 and first.startswith(shown)


# -- the documentation and the package cannot drift from the code -----------------------

def _models() -> list[type]:
    from pydantic import BaseModel

    from esair_min.components import COMPONENTS
    from esair_min.model import board as model

    # The board model's own classes and every device kind's (esair_min.components).
    modules = {model.__name__} | {c.schema.__module__ for c in COMPONENTS}
    return [cls for cls in vars(model).values()
            if isinstance(cls, type) and issubclass(cls, BaseModel)
            and cls.__module__ in modules and cls.model_fields
            and cls is not model.BoardCore]          # its fields are Board's, documented there


def test_board_format_doc_lists_every_field() -> None:
    """docs/board-format.md has a section per model, with a table row per field."""
    doc = (ROOT / "docs" / "board-format.md").read_text()
    models = _models()
    assert {m.__name__ for m in models} >= {"Board", "Servo", "Motion", "Frame", "I2c"}
    for cls in models:
        heading = re.search(rf"^(#+) .*\({cls.__name__}\)$", doc, re.MULTILINE)
        assert heading, f"docs/board-format.md has no section for {cls.__name__}"
        level = len(heading.group(1))
        rest = doc[heading.end():]
        end = re.search(rf"^#{{1,{level}}} ", rest, re.MULTILINE)
        section = rest[:end.start()] if end else rest
        for field in cls.model_fields:
            assert f"| `{field}` |" in section, \
                f"docs/board-format.md: field '{field}' of {cls.__name__} is not documented"


def test_every_python_package_is_installed() -> None:
    """`pip install .` ships every package folder (pyproject lists them explicitly)."""
    import tomllib

    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    listed = set(config["packages"])
    for top, name in (("esair_min", "esair_min"), ("esair_std", "esair_std"),
                      ("codegen", "esair_min.codegen")):
        for init in (ROOT / top).rglob("__init__.py"):
            if "codegen" in init.relative_to(ROOT).parts[1:] and top == "esair_min":
                continue                     # the checkout's link to the top-level codegen/
            package = ".".join([name, *init.parent.relative_to(ROOT / top).parts])
            assert package in listed, f"{package} is missing from pyproject.toml packages"
    assert "codegen" not in listed           # no top-level `codegen` in site-packages
    assert config["package-dir"] == {"esair_min.firmware_templates": "firmware_templates",
                                     "esair_min.boards": "boards", "esair_min.codegen": "codegen"}
    assert "**/*.yaml" in config["package-data"]["esair_min.boards"]
