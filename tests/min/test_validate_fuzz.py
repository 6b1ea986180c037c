"""Whatever YAML a user writes, the validator answers with a ConfigError (each of the
errors it holds with a mark, one line each) or a valid robot: never another exception
type.

Inputs: arbitrary YAML-able data as a whole board file, and PAPA-MAN's boards with one
change anywhere (a value replaced by a random one, a key or list item deleted, a key
added).
"""

from __future__ import annotations

import pytest

import copy
import tempfile
from pathlib import Path
from typing import Any

import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pydantic import BaseModel

from esair_min.model import board as model
from esair_min.errors import ConfigError
from esair_min.model.validate import load_robot

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
PAPAMAN = ROOT / "boards" / "papaman"
FILES = ("actuator.yaml", "central.yaml", "sensor.yaml")
ORIGINAL = {name: yaml.safe_load((PAPAMAN / name).read_text()) for name in FILES}

FIELD_NAMES = sorted({f for cls in vars(model).values()
                      if isinstance(cls, type) and issubclass(cls, BaseModel)
                      for f in cls.model_fields})

SETTINGS = settings(max_examples=50, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])

scalars = st.one_of(
    st.none(), st.booleans(),
    st.integers(min_value=-2**70, max_value=2**70),
    st.integers(min_value=-5, max_value=300),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=12),
    st.sampled_from(["central", "actuator", "sensor", "master", "slave", "eeprom", "board",
                     "RB0", "RC6", "t", "PLY", "left_foot", "balance", "play", "0x50"]),
)
keys = st.one_of(st.sampled_from(FIELD_NAMES), st.text(max_size=8))
values = st.recursive(
    scalars,
    lambda inner: st.one_of(st.lists(inner, max_size=4),
                            st.dictionaries(keys, inner, max_size=4)),
    max_leaves=12,
)


def check(files: dict[str, Any]) -> None:
    """Write ``files`` (name -> data) as YAML and load them as one robot."""
    with tempfile.TemporaryDirectory() as tmp:
        for name, data in files.items():
            (Path(tmp) / name).write_text(yaml.safe_dump(data, allow_unicode=True))
        try:
            load_robot(tmp)
        except ConfigError as exc:
            for err in exc.each():        # every error of the robot, one line each
                assert err.mark is not None and err.mark.line >= 1 and err.mark.col >= 1
                assert "\n" not in str(err)
            assert str(exc).splitlines() == exc.lines()


@SETTINGS
@given(values)
def test_arbitrary_board_file(data: Any) -> None:
    check({"board.yaml": data})


@SETTINGS
@given(st.dictionaries(st.sampled_from(FIELD_NAMES), values, min_size=1, max_size=8))
def test_board_shaped_file(data: dict[str, Any]) -> None:
    check({"central.yaml": data})


def _paths(node: Any, here: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    out = [here]
    if isinstance(node, dict):
        for k, v in node.items():
            out += _paths(v, here + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out += _paths(v, here + (i,))
    return out


PATHS = [(name, p) for name in FILES for p in _paths(ORIGINAL[name])]


@st.composite
def mutated_papaman(draw: st.DrawFn) -> dict[str, Any]:
    files = copy.deepcopy(ORIGINAL)
    name, path = draw(st.sampled_from(PATHS))
    action = draw(st.sampled_from(["replace", "delete", "add"]))
    parent = files[name]
    for part in path[:-1]:
        parent = parent[part]
    if not path:                                   # the whole file
        files[name] = draw(values)
        return files
    last = path[-1]
    node = parent[last]
    if action == "replace":
        parent[last] = draw(values)
    elif action == "delete":
        del parent[last]
    elif isinstance(node, dict):
        node[draw(keys)] = draw(values)
    elif isinstance(node, list):
        node.insert(draw(st.integers(0, len(node))), draw(values))
    else:
        parent[last] = draw(values)
    return files


@settings(SETTINGS, max_examples=100)
@given(mutated_papaman())
def test_mutated_papaman(files: dict[str, Any]) -> None:
    check(files)


def test_unmutated_papaman_is_valid() -> None:
    """The mutation test starts from a valid robot (else it would test nothing)."""
    with tempfile.TemporaryDirectory() as tmp:
        for name, data in ORIGINAL.items():
            (Path(tmp) / name).write_text(yaml.safe_dump(data))
        assert len(load_robot(tmp).motions) == 5
