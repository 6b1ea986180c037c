"""Scenario files (YAML and CSV): readings over time, and every error, word for word."""

from __future__ import annotations

from pathlib import Path

import pytest

from esair_min.emulator.papaman.scenario import load_scenario, resolve_scenario
from esair_min.errors import ConfigError

ROOT = Path(__file__).resolve().parents[2]
FIX = ROOT / "tests" / "fixtures" / "scenarios"


def test_push_yaml_and_csv_agree_while_tipping(robot):
    yaml_push = load_scenario(resolve_scenario("push", robot.source), robot.sensors)
    csv_push = load_scenario(FIX / "push.csv", robot.sensors)
    for t in (0, 1100, 1300, 2000):
        assert yaml_push.values_at(t) == csv_push.values_at(t)
    assert yaml_push.values_at(1000) == (560,) * 4 + (470,) * 4
    assert yaml_push.values_at(1200) == (680,) * 4 + (340,) * 4
    assert yaml_push.values_at(10_000) == (512,) * 8
    assert yaml_push.description.startswith("a push")


def test_quiet_and_single_sensor_steps(robot, tmp_path):
    quiet = load_scenario(resolve_scenario("quiet", robot.source), robot.sensors)
    assert all(abs(v - 512) < 10 for t in (0, 600, 2000) for v in quiet.values_at(t))
    f = tmp_path / "one.yaml"
    f.write_text("idle: 500\nsteps:\n  - {at_ms: 10, values: {r_heel_out: 900}}\n")
    sc = load_scenario(f, robot.sensors)
    assert sc.values_at(0) == (500,) * 8
    assert sc.values_at(10) == (500,) * 7 + (900,)


ERRORS = {
    "bad_header.csv": "bad_header.csv:1:1: a CSV scenario starts with a header "
                      "'t_ms,<sensor or group>,...'",
    "bad_step.yaml": "bad_step.yaml:2:5: each step is {at_ms: <time in ms>, values: <readings>}",
    "bad_values.yaml": "bad_values.yaml:2:5: 'values' must be a list (one per sensor) or a "
                       "mapping of sensor or group names to values",
    "no_steps.yaml": "no_steps.yaml:1:1: a scenario file is a mapping with 'steps:', a list "
                     "of {at_ms: ..., values: ...}",
    "not_increasing.yaml": "not_increasing.yaml:3:5: at_ms 100 must be a whole number of ms, "
                           "later than the step before",
    "not_number.csv": "not_number.csv:2:1: every column of a CSV scenario is a whole number",
    "out_of_range.yaml": "out_of_range.yaml:2:5: sensor value 1024 is not an integer 0..1023 "
                         "(10-bit ADC counts)",
    "short_row.csv": "short_row.csv:2:1: expected 3 columns as in the header, got 2",
    "syntax.yaml": "syntax.yaml:2:1: YAML syntax error: expected the node content, but found "
                   "'<stream end>'",
    "unknown_group.yaml": "unknown_group.yaml:2:5: no sensor or sensor group named 'left_fut' "
                          "(did you mean 'left_foot'?)",
    "wrong_count.yaml": "wrong_count.yaml:2:5: expected 8 values (one per sensor, in register "
                        "order), got 3",
}


@pytest.mark.parametrize("name", sorted(ERRORS))
def test_scenario_errors(robot, name):
    with pytest.raises(ConfigError) as exc:
        load_scenario(FIX / name, robot.sensors)
    assert str(exc.value) == f"{FIX / name}".replace(name, "") + ERRORS[name]


def test_missing_scenario_file(robot, tmp_path):
    with pytest.raises(ConfigError) as exc:
        load_scenario(tmp_path / "gone.yaml", robot.sensors)
    assert str(exc.value) == f"{tmp_path / 'gone.yaml'}:1:1: no such scenario file"


@pytest.mark.parametrize("arg, message", [
    ("pusj", "no scenario 'pusj' (did you mean 'push'?): give a file, or one of the robot's "
             "scenarios (push, quiet)"),
    ("nothing", "no scenario 'nothing': give a file, or one of the robot's scenarios "
                "(push, quiet)"),
])
def test_unknown_scenario_name(robot, arg, message):
    with pytest.raises(ConfigError) as exc:
        resolve_scenario(arg, robot.source)
    assert str(exc.value) == message


def test_a_held_scenario_plays_from_each_play(robot, tmp_path):
    from esair_min.emulator import Emulator

    f = tmp_path / "two.yaml"
    f.write_text("idle: 500\nsteps:\n  - {at_ms: 0, values: {left_foot: 600}}\n"
                 "  - {at_ms: 100, values: {left_foot: 700}}\n")
    emu = Emulator(robot, scenario=f, hold_scenario=True)
    emu.run_for(0.5)
    assert emu.sensor_values == (500,) * 8            # held: no step at boot
    emu.play_scenario()                                # at 0.5 s: its at_ms 0 is now
    emu.run_for(0.05)
    assert emu.sensor_values == (600,) * 4 + (500,) * 4
    emu.play_scenario()                                # again at 0.55 s: the first play's
    emu.run_for(0.06)                                  # 700 (due at 0.6 s) is dropped
    assert emu.sensor_values == (600,) * 4 + (500,) * 4
    emu.run_for(0.05)                                  # 0.66 s: the second's 700 (0.65 s)
    assert emu.sensor_values == (700,) * 4 + (500,) * 4
    assert emu.scenario_plays == 2
    unheld = Emulator(robot, scenario=f)
    unheld.run_for(0.001)
    assert unheld.sensor_values == (600,) * 4 + (500,) * 4 and unheld.scenario_plays == 1
