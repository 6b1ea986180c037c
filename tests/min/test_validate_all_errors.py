"""The validator reports every error of a robot, not the first (issue 25, item 5):
one `path:line:col: message` line each, sorted by file, line and column, at most
SHOWN_ERRORS of them and then `and N more errors (M in all)`; what makes later checks
meaningless stops them (a file that cannot be read, or that does not fit the model, is
not checked further, and the rules across boards then do not run). `esair check` prints
each as an `error:` line and exits 1, as it did for one error (docs/board-format.md,
"Errors")."""

from __future__ import annotations

import pickle
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

from esair_min.cli import main
from esair_min.errors import SHOWN_ERRORS, ConfigError, ConfigErrors, Mark
from esair_min.model.validate import check_board_alone, load_robot

ROOT = Path(__file__).resolve().parents[2]


def papaman(tmp_path: Path, changes: dict[str, list[tuple[str, str]]]) -> Path:
    """A copy of boards/papaman with each (old, new) text change made once."""
    robot = tmp_path / "robot"
    shutil.copytree(ROOT / "boards" / "papaman", robot)
    for name, edits in changes.items():
        text = (robot / name).read_text()
        for old, new in edits:
            assert text.count(old) == 1, (name, old)
            text = text.replace(old, new)
        (robot / name).write_text(text)
    return robot


#: a YAML error in one file, two board rules broken in another, three misfits in a third;
#: and a peer's register count that only the rules across boards would catch
CHANGES = {
    "actuator.yaml": [("role: actuator\n", "role: actuator: x\n")],
    "sensor.yaml": [("address: 0x20", "address: 0x99"),
                    ("l_toe_out,  channel: 1,", "l_toe_out,  channel: 11,"),
                    ("r_toe_in,   channel: 4, group:", "r_toe_in,   channel: 4, grup:")],
    "central.yaml": [("baud: 9600", "baud: 230400"), ("pin: RB0", "pin: RC6"),
                     ("registers: 24}", "registers: 22}")],
}


def expected(robot: Path) -> list[str]:
    return [
        f"{robot}/actuator.yaml:6:15: ': ' inside the value of 'role' would start a second "
        "key on one line; put the value in quotes (role: \"actuator: x\")",
        f"{robot}/central.yaml:12:9: baud 230400 cannot be made at 20000000 Hz within 2 %: "
        "best is SPBRG 4 with BRGH=1 (250000 baud, +8.51 %)",
        f"{robot}/central.yaml:17:8: pin RC6 is used twice: by the UART and by the sync "
        "line; give the sync line another pin",
        f"{robot}/sensor.yaml:12:12: 'address' must be at most 119 (0x77), not 153 (0x99)",
        f"{robot}/sensor.yaml:15:33: 'channel' must be at most 7, not 11",
        # the misspelt key only: not also "missing required key 'group'"
        f"{robot}/sensor.yaml:18:36: unknown key 'grup' (did you mean 'group'?)",
    ]


def test_every_error_of_the_robot_in_file_line_col_order(tmp_path: Path) -> None:
    robot = papaman(tmp_path, CHANGES)
    with pytest.raises(ConfigErrors) as info:
        load_robot(robot)
    err = info.value
    assert str(err).splitlines() == expected(robot)
    assert [str(e) for e in err.each()] == expected(robot)
    # its own message and mark are the first error's, as ConfigError's always were
    assert (err.mark, err.message) == (Mark(f"{robot}/actuator.yaml", 6, 15),
                                      err.each()[0].message)


def test_rules_across_boards_run_once_every_file_loads(tmp_path: Path) -> None:
    robot = papaman(tmp_path, {"central.yaml": [("baud: 9600", "baud: 230400"),
                                                ("registers: 24}", "registers: 22}")]})
    with pytest.raises(ConfigErrors) as info:
        load_robot(robot)
    assert str(info.value).splitlines() == [
        f"{robot}/central.yaml:12:9: baud 230400 cannot be made at 20000000 Hz within 2 %: "
        "best is SPBRG 4 with BRGH=1 (250000 baud, +8.51 %)",
        f"{robot}/central.yaml:23:78: device 'servos' declares 22 registers but board "
        "'actuator' has 24 (2 per servo and per sensor); set registers: 24",
    ]


def test_check_prints_each_error_on_its_own_line_and_exits_1(tmp_path: Path) -> None:
    robot = papaman(tmp_path, CHANGES)
    result = CliRunner().invoke(main, ["check", str(robot)])
    assert result.exit_code == 1
    assert result.stdout == ""
    assert result.stderr == "".join(f"error: {line}\n" for line in expected(robot))


def test_more_than_shown_errors_end_with_how_many_more(tmp_path: Path) -> None:
    """25 unknown keys: the first 20 by line, then the count."""
    extra = "".join(f"wrong_{k:02d}: 1\n" for k in range(25))
    robot = papaman(tmp_path, {"central.yaml": [("role: central\n", "role: central\n" + extra)]})
    result = CliRunner().invoke(main, ["check", str(robot)])
    assert result.exit_code == 1
    shown = [f"error: {robot}/central.yaml:{7 + k}:1: unknown key 'wrong_{k:02d}' (allowed "
             "here: board, role, description, mcu, uart, tick, sync, i2c, commands, "
             "reactions, figure, servos, sensors, mux, motions, motors, flow_sensors, base)"
             for k in range(SHOWN_ERRORS)]
    assert SHOWN_ERRORS == 20
    assert result.stderr.splitlines() == shown + ["error: and 5 more errors (25 in all)"]


def test_one_board_file_checked_alone_reports_each_of_its_errors(tmp_path: Path) -> None:
    robot = papaman(tmp_path, {"sensor.yaml": [
        ("l_toe_out,  channel: 1,", "l_toe_out,  channel: 0,"),
        ("r_toe_in,   channel: 4,", "r_toe_in,   channel: 3,")]})
    with pytest.raises(ConfigErrors) as info:
        check_board_alone(robot / "sensor.yaml")
    # a channel used twice is that rule's error, not also a pin used twice
    assert str(info.value).splitlines() == [
        f"{robot}/sensor.yaml:15:33: sensor channel 0 is already used at line 14; each "
        "sensor needs its own channel",
        f"{robot}/sensor.yaml:18:33: sensor channel 3 is already used at line 17; each "
        "sensor needs its own channel",
    ]
    result = CliRunner().invoke(main, ["check", str(robot / "sensor.yaml")])
    assert result.exit_code == 1
    assert result.stderr.count("error: ") == 2


def test_errors_cross_a_process_boundary_whole() -> None:
    errors = ConfigErrors([ConfigError("b", Mark("x.yaml", 2, 1)),
                           ConfigError("a", Mark("x.yaml", 1, 5)),
                           ConfigError("a", Mark("x.yaml", 1, 5))])
    back = pickle.loads(pickle.dumps(errors))
    assert str(back) == str(errors) == "x.yaml:1:5: a\nx.yaml:2:1: b"
    assert back.mark == Mark("x.yaml", 1, 5)


def test_each_item_of_a_kind_reports_its_own_error(tmp_path: Path) -> None:
    """Every servo with a broken rule and every broken frame, not the first only; the
    board's own errors stop the rules across boards (the frames are then not checked
    against servos whose limits are wrong)."""
    robot = papaman(tmp_path, {
        "actuator.yaml": [("l_hip_yaw,     index: 0,  pin: RD0, min_angle: 60, max_angle: 120, "
                           "stand_angle: 90", "l_hip_yaw,     index: 0,  pin: RD0, min_angle: "
                           "60, max_angle: 120, stand_angle: 130"),
                          ("l_knee,        index: 3,  pin: RD3, min_angle: 0,  max_angle: 150",
                           "l_knee,        index: 3,  pin: RD3, min_angle: 0,  max_angle: 150, "
                           "pulse_min_us: 2600")]})
    with pytest.raises(ConfigErrors) as info:
        load_robot(robot)
    assert str(info.value).splitlines() == [
        f"{robot}/actuator.yaml:19:92: servo 'l_hip_yaw': stand_angle 130 is outside its "
        "limits 60..120",
        f"{robot}/actuator.yaml:22:5: servo 'l_knee': pulse_max_us (2500) must be above "
        "pulse_min_us (2600)",
    ]
    robot = papaman(tmp_path / "frames", {"central.yaml": [
        ("{angles: [90, 90, 105, 105, 78, 90, 90, 90, 105, 105, 78, 90], speed: 3}",
         "{angles: [90, 90, 105, 105, 78, 90, 90, 90, 105, 105, 78, 190], speed: 3}"),
        ("{angles: [90, 90, 120, 120, 66, 90, 90, 90, 120, 120, 66, 90], speed: 3}",
         "{angles: [10, 90, 120, 120, 66, 90, 90, 90, 120, 120, 66, 90], speed: 3}")]})
    with pytest.raises(ConfigErrors) as info:
        load_robot(robot)
    assert [(e.mark.line, e.message) for e in info.value.each() if e.mark] == [
        (68, "motion 'sit' frame 0: angle 190 for servo 'r_ankle_roll' is outside its "
             "limits 60..120"),
        (69, "motion 'sit' frame 1: angle 10 for servo 'l_hip_yaw' is outside its limits "
             "60..120"),
    ]
