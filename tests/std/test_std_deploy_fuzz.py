"""Whatever a user writes, load_deployment answers with a DeployError (with a place)
or a Deployment: never another exception type.

Inputs: arbitrary YAML-able data as a whole file or a dict, and the issue 11 example
with one change anywhere (a value replaced, a key deleted, a key added).
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

from esair_std.deploy import DeployError, Deployment, load_deployment

pytestmark = pytest.mark.slow

EXAMPLE = yaml.safe_load(Path("tests/fixtures/std_lab/lab.yaml").read_text())
KEYS = ["robot", "mode", "endpoint", "resources", "behaviors", "reactions", "security",
        "class", "options", "allow", "uses", "period", "restart", "max", "within",
        "enabled", "rate_hz", "feet", "knee", "follow", "logger", "guard", "*"]
SETTINGS = settings(max_examples=60, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])

scalars = st.one_of(
    st.none(), st.booleans(), st.integers(min_value=-2**70, max_value=2**70),
    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=12),
    st.sampled_from(["read", "command", "configure", "thread", "process", "lab:Follow",
                     "a.b:C", "tcp/127.0.0.1:7447", "tcp/[::1]:0", "udp/x:99999", "feet",
                     "knee.x", "*", "0.02", "-1"]),
)
keys = st.one_of(st.sampled_from(KEYS), st.text(max_size=8))
values = st.recursive(scalars, lambda inner: st.one_of(
    st.lists(inner, max_size=4), st.dictionaries(keys, inner, max_size=4)), max_leaves=12)


def check(data: Any, as_file: bool) -> None:
    try:
        if as_file:
            with tempfile.TemporaryDirectory() as tmp:
                f = Path(tmp) / "d.yaml"
                f.write_text(yaml.safe_dump(data, allow_unicode=True))
                result = load_deployment(f)
        else:
            result = load_deployment(data)
    except DeployError as exc:
        assert exc.mark is not None or not as_file
        assert "\n" not in str(exc)
        return
    assert isinstance(result, Deployment)


def _paths(node: Any, prefix: tuple = ()) -> list[tuple]:
    out = [prefix] if prefix else []
    if isinstance(node, dict):
        for k, v in node.items():
            out += _paths(v, prefix + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out += _paths(v, prefix + (i,))
    return out


PATHS = _paths(EXAMPLE)


@SETTINGS
@given(data=st.dictionaries(keys, values, max_size=6), as_file=st.booleans())
def test_any_mapping(data, as_file):
    check(data, as_file)


@SETTINGS
@given(where=st.sampled_from(PATHS), value=values, how=st.sampled_from(["set", "del", "add"]),
       key=keys, as_file=st.booleans())
def test_example_with_one_change(where, value, how, key, as_file):
    data = copy.deepcopy(EXAMPLE)
    parent = data
    for part in where[:-1]:
        parent = parent[part]
    if how == "set":
        parent[where[-1]] = value
    elif how == "del":
        del parent[where[-1]]
    else:
        target = parent[where[-1]]
        if isinstance(target, dict):
            target[key] = value
        elif isinstance(target, list):
            target.append(value)
        else:
            parent[where[-1]] = {key: value}
    check(data, as_file)


def test_the_example_itself_loads():
    check(copy.deepcopy(EXAMPLE), True)
    check(copy.deepcopy(EXAMPLE), False)


yaml_text = st.lists(st.sampled_from(
    ["robot: lab\n", "resources:\n", "  feet: {class: 'a:B', allow: {'*': read}}\n",
     "behaviors:\n", "  f: {class: 'a:C', uses: {feet: command}}\n", "  - x\n", "\t",
     ": ", "{", "}", "[", "]", "'", '"', "&a ", "*a ", "!!python/object ", "\n", "  ",
     "period: 0\n", "key", "#", "---\n", "\x00", "é"]), max_size=20).map("".join)


@SETTINGS
@given(text=yaml_text)
def test_any_text(text):
    with tempfile.TemporaryDirectory() as tmp:
        f = Path(tmp) / "d.yaml"
        f.write_text(text, encoding="utf-8")
        try:
            result = load_deployment(f)
        except DeployError as exc:
            assert exc.mark is not None and "\n" not in str(exc)
            return
    assert isinstance(result, Deployment)
