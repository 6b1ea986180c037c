"""The deployment file: the issue 11 example loads as is, into a frozen model in file
order; its JSON Schema accepts it; ``esair std check``/``schema``; class import."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import jsonschema
import pydantic
import pytest
import yaml
from click.testing import CliRunner

from esair_min.cli import main
from esair_std import Level
from esair_std.deploy import (DEFAULT_ENDPOINT, BehaviorSpec, DeployError, Deployment,
                              ReactionSpec, ResourceSpec, RestartPolicy, SecuritySpec,
                              bundled_examples, deployment_schema, load_class, load_classes,
                              load_deployment, resolve_deployment)

LAB = Path("tests/fixtures/std_lab")
EXAMPLE = LAB / "lab.yaml"


def test_issue_example_loads_as_is():
    dep = load_deployment(EXAMPLE)
    assert (dep.robot, dep.mode, dep.endpoint) == ("lab", "thread", "tcp/127.0.0.1:7447")
    assert list(dep.resources) == ["feet", "knee"]
    assert list(dep.behaviors) == ["follow", "logger"]
    assert list(dep.reactions) == ["guard"]
    feet, knee = dep.resources.values()
    assert (feet.name, feet.class_path, feet.options) == ("feet", "lab_drivers:Feet",
                                                          {"rate_hz": 50})
    assert feet.allow == {"*": Level.read}
    assert knee.allow == {"follow": Level.command, "tuner": Level.configure}
    follow = dep.behaviors["follow"]
    assert (follow.period, follow.uses) == (0.02, {"feet": Level.read, "knee": Level.command})
    assert (follow.restart.max, follow.restart.within) == (3, 5.0)
    logger = dep.behaviors["logger"]
    assert (logger.period, logger.uses, logger.restart.max, logger.options) == (None, {}, 0, {})
    guard = dep.reactions["guard"]
    assert (guard.resources, guard.enabled, guard.period) == (("feet", "knee"), True, None)
    # what the loader adds: where each came from
    assert dep.source == str(EXAMPLE)
    assert dep.base_dir == EXAMPLE.resolve().parent == follow.base_dir
    assert (follow.mark.path, follow.mark.line, follow.mark.col) == (str(EXAMPLE), 8, 3)
    assert (follow.class_mark.line, follow.class_mark.col) == (8, 19)
    assert [(k, s.name) for k, s in dep.components()] == [
        ("resource", "feet"), ("resource", "knee"), ("behavior", "follow"),
        ("behavior", "logger"), ("reaction", "guard")]
    assert dep.component("guard") is guard and dep.component("nobody") is None


def test_defaults_and_frozen():
    dep = load_deployment({"robot": "r"})
    assert (dep.mode, dep.endpoint, dep.resources, dep.security) == ("thread", DEFAULT_ENDPOINT,
                                                                     {}, None)
    assert dep.source is None and dep.base_dir == Path.cwd()
    with pytest.raises(pydantic.ValidationError):
        dep.robot = "other"  # type: ignore[misc]
    with pytest.raises(pydantic.ValidationError):
        BehaviorSpec.model_validate({"class": "a:B"}).period = 1  # type: ignore[misc]


def test_levels_are_ordered():
    assert Level.read < Level.command < Level.configure
    assert Level.parse("command") is Level.command and str(Level.configure) == "configure"
    with pytest.raises(ValueError):
        Level.parse("write")


def test_allow_patterns_and_children():
    dep = load_deployment({
        "robot": "r",
        "resources": {"papaman": {"class": "m:Link", "allow": {"walk_*": "command",
                                                                "walk_slow": "read",
                                                                "*": "read"}}},
        "behaviors": {"walk_fast": {"class": "m:W", "uses": {"papaman.servo.*": "command",
                                                             "papaman.feet": "read"}}},
        "reactions": {"guard": {"class": "m:G", "resources": ["papaman.feet"],
                                "enabled": False, "period": 0.5}},
    })
    papaman = dep.resources["papaman"]
    assert papaman.granted("walk_fast") is Level.command
    assert papaman.granted("walk_slow") is Level.command     # the highest matching grant
    assert papaman.granted("anyone") is Level.read
    assert dep.reactions["guard"].enabled is False


def test_options_gathered_and_explicit():
    dep = load_deployment({"robot": "r", "resources": {"s": {
        "class": "m:S", "rate_hz": 10, "port": "/dev/ttyUSB0",
        "options": {"perod": 3, "allow": "x"}}}})
    # under options: any name, even one that looks like a key
    assert dep.resources["s"].options == {"rate_hz": 10, "port": "/dev/ttyUSB0", "perod": 3,
                                          "allow": "x"}


def test_yaml_empty_sections_and_ipv6(tmp_path):
    f = tmp_path / "d.yaml"
    f.write_text("robot: r\nendpoint: tcp/[::1]:7447\nresources:\nbehaviors:\n")
    dep = load_deployment(f)
    assert (dep.endpoint, dep.resources, dep.behaviors) == ("tcp/[::1]:7447", {}, {})


def test_security_is_the_transport_section():
    dep = load_deployment({"robot": "r", "security": {"ca": "ca.pem", "cert": "s.pem",
                                                      "key": "s.key"}})
    assert (str(dep.security.ca), dep.security.mtls, dep.security.lease_ms) == ("ca.pem", True,
                                                                                2000)


def test_model_dump_round_trip():
    dep = load_deployment(EXAMPLE)
    again = load_deployment(dep.model_dump(by_alias=True, exclude_none=True))
    assert again.model_dump() == dep.model_dump()


def test_json_schema_validates_the_example():
    schema = deployment_schema()
    jsonschema.Draft202012Validator.check_schema(schema)
    validator = jsonschema.Draft202012Validator(schema)
    validator.validate(yaml.safe_load(EXAMPLE.read_text()))
    for bad in ({"robot": "Lab"}, {"robot": "lab", "mode": "thred"},
                {"robot": "lab", "behaviors": {"f": {"class": "a.B"}}},
                {"robot": "lab", "behaviors": {"f": {"class": "a:B", "period": 0}}},
                {"robot": "lab", "behaviors": {"f": {"class": "a:B", "uses": {"x": "write"}}}},
                {"robot": "lab", "endpoint": "tcp:1.2.3.4:5"},
                {"robot": "lab", "colour": 1}):
        assert not validator.is_valid(bad), bad
    # keys the loader fills are not part of the file format
    assert "base_dir" not in schema["properties"] and "source" not in schema["properties"]
    assert set(schema["$defs"]["BehaviorSpec"]["properties"]) == {
        "class", "options", "period", "uses", "restart"}


def test_schema_cli():
    result = CliRunner().invoke(main, ["std", "schema"])
    assert result.exit_code == 0
    assert json.loads(result.output) == json.loads(json.dumps(deployment_schema()))
    assert json.loads(result.output)["title"] == "ESAIR STD deployment file"


def test_check_cli_prints_a_summary():
    result = CliRunner().invoke(main, ["std", "check", str(EXAMPLE)])
    assert result.exit_code == 0, result.output
    assert result.output == (
        "robot 'lab': mode thread, endpoint tcp/127.0.0.1:7447, 2 resources, 2 behaviors, "
        "1 reaction\n"
        "  resource feet    lab_drivers:Feet  allow *: read  options rate_hz=50\n"
        "  resource knee    lab_drivers:Knee  allow follow: command, tuner: configure\n"
        "  behavior follow  lab:Follow  period 0.02 s  uses feet: read, knee: command  "
        "restart 3 times in 5 s\n"
        "  behavior logger  lab:Logger  period of the class  no restart\n"
        "  reaction guard   lab:Guard  resources feet, knee  enabled\n"
        "  classes: 5 imported\n"
        f"note: {EXAMPLE}:6:63: resource 'knee' allows 'tuner', which is not a behavior of "
        "this file; one added at run time may use it\n"
        "ok\n")


def test_check_cli_note_did_you_mean(tmp_path):
    f = tmp_path / "d.yaml"
    f.write_text("robot: r\nresources:\n  s: {class: 'm:S', allow: {folow: read}}\n"
                 "behaviors:\n  follow: {class: 'm:F'}\n")
    result = CliRunner().invoke(main, ["std", "check", "--no-import", str(f)])
    assert result.exit_code == 0
    assert f"note: {f}:3:29: resource 's' allows 'folow', which is not a behavior of this " \
           "file (did you mean 'follow'?); one added at run time may use it\n" in result.output


def test_load_class_from_the_deployment_folder_first(tmp_path):
    dep = load_deployment(EXAMPLE)
    classes = load_classes(dep)
    assert [c.__name__ for c in classes.values()] == ["Feet", "Knee", "Follow", "Logger",
                                                      "Guard"]
    assert Path(sys.modules["lab"].__file__).resolve() == (LAB / "lab.py").resolve()
    # another folder with its own 'lab' module: that one is imported for its deployment
    (tmp_path / "lab.py").write_text("class Follow:\n    where = 'tmp'\n")
    other = load_class("lab:Follow", tmp_path)
    assert other.where == "tmp"
    again = load_class(dep.behaviors["follow"])
    assert not hasattr(again, "where")
    assert Path(sys.modules["lab"].__file__).resolve() == (LAB / "lab.py").resolve()


def test_load_class_then_sys_path():
    assert load_class("json.decoder:JSONDecoder", "/nonexistent").__name__ == "JSONDecoder"
    with pytest.raises(DeployError) as info:
        load_class("json:dumps")
    assert str(info.value) == "'json:dumps' is a function, not a class"


def test_bundled_example_by_name_and_folder():
    for arg in ("papaman", "esair_std/examples/papaman"):
        result = CliRunner().invoke(main, ["std", "check", "--no-import", arg])
        assert result.exit_code == 0, result.output
        assert result.output.startswith("robot 'papaman': mode thread")
    assert resolve_deployment("papaman").name == "papaman.yaml"
    assert "papaman" in bundled_examples()


DOC = Path("docs/std-deployment.md").read_text()


@pytest.mark.parametrize("model", [Deployment, ResourceSpec, BehaviorSpec, ReactionSpec,
                                   RestartPolicy, SecuritySpec])
def test_every_key_is_documented_in_its_section(model):
    """docs/std-deployment.md has a section per model, '## ... (Model)', with a table
    row for each key of the file format."""
    head = DOC.index(f"({model.__name__})")
    section = DOC[head:DOC.find("\n## ", head)]
    keys = [f.alias or n for n, f in model.model_fields.items() if not f.exclude]
    for key in keys:
        assert f"| `{key}` |" in section, f"{model.__name__}.{key} not documented"


def test_std_group_is_mounted_in_esair():
    result = CliRunner().invoke(main, ["--help"])
    assert result.exit_code == 0 and "\n  std " in result.output
    result = CliRunner().invoke(main, ["std", "--help"])
    assert result.exit_code == 0
    assert "check" in result.output and "schema" in result.output
