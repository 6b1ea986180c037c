"""A MinLink entry's options are a schema (esair_std/drivers/minlink/options.py), and so
are a Starfish entry's (drivers/starfish/options.py): a bad one is a deployment error at
its line, like every other (each fixture file: one error), and the driver words the same
error by the option's path for an entry with no file."""

from pathlib import Path

import pytest

from esair_std.deploy import load_classes, load_deployment
from esair_std.deploy.class_options import check_options
from esair_std.drivers.minlink.options import MinLinkOptions
from esair_std.errors import DeployError

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "std_minlink_options"


@pytest.mark.parametrize("name, message", [
    ("feet_hz_text", ":6:14: 'feet_hz' must be a number, not text 'fast'"),
    ("deadline_zero", ":6:15: 'deadline' must be greater than 0.0, not 0"),
    ("duplex_text", ":6:13: 'duplex' must be true or false, not text 'yes'"),
    ("no_port", ":3:3: missing required key 'port'"),
    ("restart_max_negative", ":7:48: 'max' must be at least 0, not -1"),   # under options:
    ("restart_key_misspelt", ":5:33: unknown key 'whithin' (did you mean 'within'?)"),
    # STARFISH's driver: its own schema (esair_std/drivers/starfish/options.py)
    ("starfish_radio_range_text", ":6:22: 'range_m' must be a number, not text 'far'"),
])
def test_a_bad_option_is_reported_at_its_line(name, message):
    path = FIXTURES / f"{name}.yaml"
    dep = load_deployment(path)                 # the deployment itself is fine
    with pytest.raises(DeployError) as exc:
        load_classes(dep)
    assert str(exc.value) == f"{path}{message}"


def test_without_a_file_the_error_names_the_options_path():
    with pytest.raises(DeployError) as exc:
        check_options(MinLinkOptions, {"port": "emulate", "emulate": {"restart": {"max": "x"}}})
    assert str(exc.value) == "emulate.restart.max: 'max' must be an integer, not text 'x'"


def test_good_options_keep_their_values_and_defaults():
    o = check_options(MinLinkOptions, {"port": "emulate", "feet_hz": 4, "allow": {"*": "read"},
                                       "emulate": {"scenario": "push",
                                                   "restart": {"max": 3, "within": 60}}})
    assert isinstance(o, MinLinkOptions)
    assert (o.port, o.feet_hz, o.feet_share, o.timeout, o.deadline, o.duplex) == \
        ("emulate", 4.0, 0.5, None, 0.5, True)
    assert (o.emulate.restart.max, o.emulate.restart.within) == (3, 60.0)
    assert o.emulate.args() == {"scenario": "push"}


@pytest.mark.parametrize("options, timeout", [
    ({"port": "emulate"}, 3.0),                      # the emulator shares the host's cores
    ({"port": "/dev/ttyUSB0"}, 1.0),
    ({"port": "emulate", "timeout": 0.5}, 0.5),      # named: as named
    ({"port": "/dev/ttyUSB0", "timeout": 2}, 2.0),
])
def test_the_reply_timeout_defaults_by_the_kind_of_port(options, timeout):
    from esair_std.drivers.minlink.driver import _Options

    o = check_options(MinLinkOptions, options)
    assert isinstance(o, MinLinkOptions)
    assert _Options(o.model_dump(mode="json")).timeout == timeout
