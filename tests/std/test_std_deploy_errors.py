"""Every bad deployment gives one exact, one-line ``path:line:col: message``.

Each case is one file under tests/fixtures/std_bad/: the issue 11 example with one
change (named on its first line). Import failures (a class that cannot be imported)
are cases under tests/fixtures/std_lab/, next to the modules they import.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from esair_min.cli import main
from esair_min.errors import ConfigError
from esair_std.deploy import DeployError, load_class, load_classes, load_deployment

BAD = Path("tests/fixtures/std_bad")
LAB = Path("tests/fixtures/std_lab")

EXPECTED = {
    "allow_level_misspelt":
        ":6:64: '*' must be one of 'read', 'command' or 'configure', not text 'reed' (did you mean 'read'?)",
    "class_dot_not_colon":
        ":9:19: 'class' must be module:Class (a module path, a colon, a class name), not text 'lab.Follow' (did you mean 'lab:Follow'?)",
    "class_missing":
        ":11:11: missing required key 'class'",
    "class_no_module":
        ":9:19: 'class' must be module:Class (a module path, a colon, a class name), not text 'Follow'",
    "class_not_text":
        ":9:19: 'class' must be text, not an integer 42",
    "component_name":
        ":7:3: resource name 'Knee' must be a lower-case name (a-z, 0-9, _; at most 32 characters, starting with a letter)",
    "component_name_dot":
        ":7:3: resource name 'knee.left' must be a lower-case name (a-z, 0-9, _; at most 32 characters, starting with a letter)",
    "duplicate_key":
        ":11:3: duplicate key 'follow' (first given at line 9); keep only one of them",
    "duplicate_name":
        ":13:3: name 'feet' is already used by a resource (line 6); resources, behaviors and reactions need distinct names",
    "empty":
        ':1:1: file is empty, expected a deployment (robot:, resources:, behaviors:, ...)',
    "enabled_not_bool":
        ":13:66: 'enabled' must be true or false, not text 'maybe'",
    "endpoint_host":
        ":4:11: 'endpoint' host '::1' is not an IP address or host name (write an IPv6 address in brackets: [::1])",
    "endpoint_no_port":
        ":4:11: 'endpoint' needs a host and a port: PROTOCOL/HOST:PORT such as tcp/127.0.0.1:7447, not text 'tcp/localhost'",
    "endpoint_no_slash":
        ":4:11: 'endpoint' must be PROTOCOL/HOST:PORT such as tcp/127.0.0.1:7447, not text 'tcp:127.0.0.1:7447'",
    "endpoint_port_range":
        ":4:11: 'endpoint' port must be a number from 0 to 65535, not '74470'",
    "endpoint_protocol":
        ":4:11: 'endpoint' protocol 'tpc' is not one of tcp, udp, tls, quic, ws or unixsock-stream (did you mean 'tcp'?)",
    "entry_key_misspelt":
        ":9:33: unknown key 'perod' (did you mean 'period'?); to pass it to the component as an option, put it under 'options:'",
    "entry_key_of_other_section":
        ":11:33: 'allow' is a key of resources, not of a behavior; to pass it to the component as an option, put it under 'options:'",
    "entry_not_mapping":
        ":11:11: 'logger' must be a mapping of keys, not text 'lab:Logger'",
    "level_misspelt":
        ":9:72: 'knee' must be one of 'read', 'command' or 'configure', not text 'comand' (did you mean 'command'?)",
    "level_not_text":
        ":9:72: 'knee' must be one of 'read', 'command' or 'configure', not an integer 2",
    "mode_misspelt":
        ":3:7: 'mode' must be one of 'thread' or 'process', not text 'thred' (did you mean 'thread'?)",
    "not_a_mapping":
        ':1:1: the file is a list; a deployment file must be a mapping of keys (robot:, resources:, behaviors:, ...)',
    "option_twice":
        ":6:61: option 'rate_hz' is given both as a key of the entry and under 'options:'; keep one",
    "options_not_mapping":
        ":11:42: 'options' must be a mapping of keys, not a list [1, 2]",
    "period_infinite":
        ":9:41: 'period' must be a finite number, not a number inf",
    "period_negative":
        ":9:41: 'period' must be greater than 0 (seconds), not -0.5",
    "period_text":
        ":9:41: 'period' must be a number, not text 'fast'",
    "period_zero":
        ":9:41: 'period' must be greater than 0 (seconds), not 0",
    "rate_hz_zero":
        ":6:47: 'rate_hz' must be a number greater than 0 (samples per second), not an integer 0",
    "reaction_resource_pattern":
        ":13:50: 'resources[1]' must be a resource name or entry.child (lower-case names joined by '.'), not text 'kn*'",
    "reaction_resources_not_list":
        ":13:43: 'resources' must be a list, not text 'feet'",
    "reaction_unknown_resource":
        ":13:50: reaction 'guard' names unknown resource 'kne' (did you mean 'knee'?)",
    "restart_key_misspelt":
        ":10:30: unknown key 'withn' (did you mean 'within'?)",
    "restart_negative":
        ":10:27: 'max' must be at least 0, not -1",
    "restart_not_integer":
        ":10:27: 'max' must be an integer, not a number 2.5",
    "restart_not_mapping":
        ":10:21: 'restart' must be a mapping of keys, not text 'always'",
    "restart_within_zero":
        ":10:38: 'within' must be greater than 0 (seconds), not 0",
    "robot_missing":
        ":2:1: missing required key 'robot'",
    "robot_name":
        ":2:8: 'robot' must be a lower-case name (a-z, 0-9, _; at most 32 characters, starting with a letter), not text 'Lab'",
    "section_not_mapping":
        ":12:12: 'reactions' must be a mapping of keys, not a list ['guard']",
    "security_ca_not_text":
        ":4:7: 'ca' must be a path (text), not an integer 5",
    "security_cert_without_key":
        ":3:11: 'security': 'cert' and 'key' go together",
    "security_not_mapping":
        ":3:11: 'security' must be a mapping of keys, not true",
    "tab_indent":
        ":3:1: a tab character: YAML indents with spaces only; replace the tab by spaces",
    "top_key_misspelt":
        ":8:1: unknown key 'behaviours' (did you mean 'behaviors'?)",
    "top_key_unknown":
        ":3:1: unknown key 'colour' (allowed here: robot, mode, endpoint, resources, behaviors, reactions, security)",
    "uses_above_allow":
        ":9:72: behavior 'follow' uses 'knee' at level 'configure', but resource 'knee' allows it only up to 'command'",
    "uses_bad_name":
        ":9:54: 'Feet' in 'uses' must be a resource name, entry.child or a pattern (a-z, 0-9, _, '.', '-' and the wildcards * ? [ ] !)",
    "uses_glob_not_allowed":
        ":9:59: behavior 'follow' uses '*' at level 'configure', but the resources it names (feet, knee) allow it only up to 'command'",
    "uses_not_allowed":
        ":9:72: behavior 'follow' uses 'knee' at level 'command', but resource 'knee' does not allow it (add 'follow: command' to its allow)",
    "uses_unknown_child":
        ":9:66: behavior 'follow' uses unknown resource 'kne.motor' (did you mean 'knee.motor'?)",
    "uses_unknown_resource":
        ":9:66: behavior 'follow' uses unknown resource 'knea' (did you mean 'knee'?)",
}

IMPORT_EXPECTED = {
    "import_dependency":
        ":9:19: importing module 'broken_needs' failed at tests/fixtures/std_lab/broken_needs.py:3: ModuleNotFoundError: No module named 'esair_no_such_dependency'",
    "import_missing_class":
        ":9:19: module 'lab' has no class 'Folow' (did you mean 'Follow'?)",
    "import_missing_module":
        ":9:19: no module named 'labb' (did you mean 'lab'?); looked in the deployment's folder, then sys.path",
    "import_missing_submodule":
        ":7:18: no module named 'json.decodr' (did you mean 'json.decoder'?); looked in the deployment's folder, then sys.path",
    "import_not_a_class":
        ":9:19: 'lab:helper' is a function, not a class",
    "import_raises":
        ":9:19: importing module 'broken_raises' failed at tests/fixtures/std_lab/broken_raises.py:3: ZeroDivisionError: division by zero",
    "import_syntax":
        ":9:19: importing module 'broken_syntax' failed at tests/fixtures/std_lab/broken_syntax.py:3: SyntaxError: invalid syntax",
    "import_wrong_base":
        ":11:19: 'lab_drivers:Feet' is not a Behavior (it must derive from esair_std.Behavior)",
    "import_wrong_base_resource":
        ":7:18: 'lab:Guard' is not a Sensor, Actuator or Driver (it must derive from esair_std.Sensor, esair_std.Actuator or esair_std.Driver)",
}


def test_every_fixture_has_a_message():
    assert sorted(p.stem for p in BAD.glob("*.yaml")) == sorted(EXPECTED)
    assert sorted(p.stem for p in LAB.glob("import_*.yaml")) == sorted(IMPORT_EXPECTED)


@pytest.mark.parametrize("case", sorted(EXPECTED))
def test_bad_deployment(case: str):
    path = f"{BAD}/{case}.yaml"
    with pytest.raises(DeployError) as info:
        load_deployment(path)
    assert str(info.value) == path + EXPECTED[case]
    assert isinstance(info.value, ConfigError)       # one error family with MIN's files


@pytest.mark.parametrize("case", sorted(IMPORT_EXPECTED))
def test_class_that_cannot_be_imported(case: str):
    path = f"{LAB}/{case}.yaml"
    dep = load_deployment(path)                      # the file itself is valid
    with pytest.raises(DeployError) as info:
        load_classes(dep)
    assert str(info.value) == path + IMPORT_EXPECTED[case]


@pytest.mark.parametrize("case", ["uses_above_allow", "top_key_misspelt"])
def test_check_cli_error(case: str):
    result = CliRunner().invoke(main, ["std", "check", f"{BAD}/{case}.yaml"])
    assert result.exit_code == 1
    assert result.output == f"error: {BAD}/{case}.yaml{EXPECTED[case]}\n"


def test_check_cli_import_error():
    path = f"{LAB}/import_missing_class.yaml"
    result = CliRunner().invoke(main, ["std", "check", path])
    assert (result.exit_code, result.output) == (
        1, f"error: {path}{IMPORT_EXPECTED['import_missing_class']}\n")
    # --no-import checks the file only
    result = CliRunner().invoke(main, ["std", "check", "--no-import", path])
    assert result.exit_code == 0 and result.output.endswith("ok\n")


def test_unknown_bundled_example():
    result = CliRunner().invoke(main, ["std", "check", "papamn"])
    assert (result.exit_code, result.output) == (
        1, "error: papamn: no such file, and no bundled example named 'papamn' (did you "
           "mean 'papaman'?) (bundled: lab, papaman, starfish)\n")


def test_missing_and_folder_files(tmp_path):
    with pytest.raises(DeployError) as info:
        load_deployment(tmp_path / "nope.yaml")
    assert str(info.value) == f"{tmp_path}/nope.yaml: no such file or folder"   # no invented line:col
    with pytest.raises(DeployError) as info:
        load_deployment(tmp_path)
    assert str(info.value) == (f"{tmp_path}:1:1: is a folder, but a deployment file (YAML) "
                               "was expected here; rename or move it")


# A deployment given as a dict: the same checks, the value's path instead of a line.
EXAMPLE = {
    "robot": "lab",
    "resources": {"feet": {"class": "lab_drivers:Feet", "rate_hz": 50, "allow": {"*": "read"}},
                  "knee": {"class": "lab_drivers:Knee", "allow": {"follow": "command"}}},
    "behaviors": {"follow": {"class": "lab:Follow", "period": 0.02,
                             "uses": {"feet": "read", "knee": "command"}}},
    "reactions": {"guard": {"class": "lab:Guard", "resources": ["feet", "knee"]}},
}

DICT_CASES = [
    (("behaviors", "follow", "period"), 0,
     "behaviors.follow.period: 'period' must be greater than 0 (seconds), not 0"),
    (("behaviors", "follow", "uses", "knee"), "configure",
     "behaviors.follow.uses.knee: behavior 'follow' uses 'knee' at level 'configure', but "
     "resource 'knee' allows it only up to 'command'"),
    (("behaviors", "follow", "uses", "papaman.servo.*"), "read",
     "behaviors.follow.uses['papaman.servo.*']: behavior 'follow' uses unknown resource "
     "'papaman.servo.*'"),
    (("reactions", "guard", "resources"), ["feet", "kne"],
     "reactions.guard.resources[1]: reaction 'guard' names unknown resource 'kne' "
     "(did you mean 'knee'?)"),
    (("resources", "knee", "class"), "lab_drivers.Knee",
     "resources.knee.class: 'class' must be module:Class (a module path, a colon, a class "
     "name), not text 'lab_drivers.Knee' (did you mean 'lab_drivers:Knee'?)"),
    (("mode",), "proces",
     "mode: 'mode' must be one of 'thread' or 'process', not text 'proces' "
     "(did you mean 'process'?)"),
    (("behaviors", "follow", "restart"), {"max": 2, "within": 1, "every": 3},
     "behaviors.follow.restart.every: unknown key 'every' (allowed here: max, within)"),
    (("robot",), None, "robot: 'robot' has no value; give it one or remove the key"),
]


def _with(loc, value):
    import copy

    data = copy.deepcopy(EXAMPLE)
    node = data
    for part in loc[:-1]:
        node = node[part]
    node[loc[-1]] = value
    return data


@pytest.mark.parametrize("loc, value, message", DICT_CASES)
def test_bad_dict(loc, value, message):
    with pytest.raises(DeployError) as info:
        load_deployment(_with(loc, value))
    assert str(info.value) == message


def test_bad_dict_shapes():
    with pytest.raises(DeployError) as info:
        load_deployment({"robot": "lab", "behaviors": {1: {"class": "a:B"}}})
    assert str(info.value) == "behaviors: key 1 must be a name (text), not int"
    loop: dict = {"robot": "lab"}
    loop["resources"] = {"a": loop}
    with pytest.raises(DeployError) as info:
        load_deployment(loop)
    assert str(info.value) == "resources.a: this list or mapping contains itself " \
                              "(endless recursion)"
    with pytest.raises(DeployError) as info:
        load_deployment(42)  # type: ignore[arg-type]
    assert str(info.value) == "a deployment is a file path or a mapping, not int"


def test_load_class_from_a_string_has_no_mark():
    with pytest.raises(DeployError) as info:
        load_class("lab:Folow", LAB)
    assert str(info.value) == "module 'lab' has no class 'Folow' (did you mean 'Follow'?)"
    with pytest.raises(DeployError) as info:
        load_class("lab", LAB)
    assert str(info.value) == ("'class' must be module:Class (a module path, a colon, a "
                               "class name), not 'lab'")


def test_load_class_checks_the_base_class():
    with pytest.raises(DeployError) as info:
        load_class("lab:Follow", LAB, expect=json.JSONDecoder)
    assert str(info.value) == ("'lab:Follow' is not a JSONDecoder (it must derive from "
                               "json.decoder.JSONDecoder)")
