"""STARFISH's boards (issue 22): the device kinds as components, the two board files,
what ``esair check``/``generate`` say about them, and every new rule's message word for
word, each with its own fixture (tests/fixtures/bad_starfish/<case>/: a copy of
boards/starfish with one change, named on the changed file's first line)."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from esair_min.cli import main
from esair_min.codegen import render_robot
from esair_min.components import COMPONENTS, component
from esair_min.components.dc_motor import pwm_units
from esair_min.errors import GenerateError
from esair_min.model.board import Board
from esair_min.model.validate import ROLE_SECTIONS
from tests.support.bad_boards import assert_refused, cases

BAD = Path("tests/fixtures/bad_starfish")

EXPECTED = {
    "base_without_drive": "tests/fixtures/bad_starfish/base_without_drive/central.yaml:22:1: 'base' needs a drive board (role: drive) with 3 motors in this robot",  # noqa: E501
    "ccp_wrong_pin": "tests/fixtures/bad_starfish/ccp_wrong_pin/drive.yaml:22:38: motor 'right': CCP2 drives pin RC1 on the pic18f452, not RD2; set pwm_pin: RC1 or pwm: software",  # noqa: E501
    "commands_on_base": "tests/fixtures/bad_starfish/commands_on_base/central.yaml:27:1: an omni base's commands are fixed (docs/protocol.md, STARFISH); remove 'commands'",  # noqa: E501
    "drive_without_base": "tests/fixtures/bad_starfish/drive_without_base/drive.yaml:7:7: a drive board needs 'base:' on the central board (the omni-wheel kinematics that drive it)",  # noqa: E501
    "index_gap": "tests/fixtures/bad_starfish/index_gap/drive.yaml:22:26: motor 'right': index 3 leaves a gap; motor indices must run 0..2 and index 2 is missing",  # noqa: E501
    "limit_above_full": "tests/fixtures/bad_starfish/limit_above_full/drive.yaml:19:61: motor 'front': limit_mm_s 900 is above its full speed (754 mm/s at 300 rpm with a 24 mm wheel); lower the limit",  # noqa: E501
    "pin_twice": "tests/fixtures/bad_starfish/pin_twice/drive.yaml:20:52: pin RD0 is used twice: by motor 'front' direction and by motor 'left' direction; give motor 'left' direction another pin",  # noqa: E501
    "singular_wheels": "tests/fixtures/bad_starfish/singular_wheels/drive.yaml:17:1: the wheels' mount angles do not let the base move in every direction (the kinematics cannot be inverted); place the wheels at different angles, e.g. 90, 210, 330",  # noqa: E501
    "three_flow": "tests/fixtures/bad_starfish/three_flow/central.yaml:32:5: at most 2 flow sensors fit the odometry reply; remove 1",  # noqa: E501
    "two_wheels": "tests/fixtures/bad_starfish/two_wheels/drive.yaml:17:1: an omni base has 3 wheels, but this drive board has 2 motors",  # noqa: E501
}


def test_every_fixture_has_its_message():
    assert cases(BAD) == sorted(EXPECTED)


@pytest.mark.parametrize("case", sorted(EXPECTED))
def test_bad_starfish_message(case):
    assert_refused(BAD / case, EXPECTED[case])


def test_esair_check_starfish_prints_the_pwm_assignment():
    result = CliRunner().invoke(main, ["check", "starfish"])
    assert result.exit_code == 0, result.output
    assert result.output.splitlines()[0] == \
        "robot 'starfish': 2 boards (central [central], drive [drive])"
    assert result.output.splitlines()[-4:] == [
        "  flow sensors: flow_left at (0, 80) mm, SCLK RB1 SDIO RB2, flow_right at (0, -80) "
        "mm, SCLK RB3 SDIO RB4",
        "  base: omni, watchdog 500 ms, |v| <= 500 mm/s, |omega| <= 3000 mrad/s",
        "  motors: front CCP1 (RC2), left CCP2 (RC1), right software PWM (RD2)",
        "ok",
    ]


def test_pwm_auto_follows_the_pin(starfish):
    drive = starfish.board("drive")
    assert pwm_units(drive.motors, drive.spec) == {"front": "ccp1", "left": "ccp2", "right": "software"}
    assert drive.register_count == 6 and starfish.peer("drive").registers == 6


def test_generate_starfish(starfish, tmp_path):
    files = render_robot(starfish)
    assert sorted(files) == [
        "central/Makefile", "central/core/es_config.h", "central/core/omni.c",
        "central/core/omni.h", "central/hal.h", "central/main.c",
        "central/ports/host/hal_host.c", "central/ports/pic18f452/hal_pic.c",
        "drive/Makefile", "drive/core/drive.c", "drive/core/drive.h", "drive/core/es_config.h",
        "drive/hal.h", "drive/main.c", "drive/ports/host/hal_host.c",
        "drive/ports/pic18f452/hal_pic.c"]
    result = CliRunner().invoke(main, ["generate", "starfish", "-o", str(tmp_path)])
    assert (result.exit_code, result.output) == (
        0, f"central, drive: 16 files written, 0 unchanged in {tmp_path}\n")


def test_a_board_whose_kinds_have_no_templates_is_skipped(starfish, tmp_path, monkeypatch):
    import dataclasses

    from esair_min.codegen import generate as gen

    kinds = tuple(dataclasses.replace(k, generated=False) if k.kind == "dc_motor" else k
                  for k in COMPONENTS)
    monkeypatch.setattr(gen, "COMPONENTS", kinds)
    assert sorted({name.split("/")[0] for name in render_robot(starfish)}) == ["central"]
    result = CliRunner().invoke(main, ["generate", "starfish", "-o", str(tmp_path)])
    assert result.output == (
        f"central: 8 files written, 0 unchanged in {tmp_path}\n"
        "not generated: drive (dc_motor): no firmware templates for these device kinds yet "
        "(their Python cores run in the emulator)\n")
    drive_only = dataclasses.replace(starfish, boards=(starfish.board("drive"),),
                                     files=(starfish.files[1],))
    with pytest.raises(GenerateError) as exc:
        render_robot(drive_only)
    assert str(exc.value) == "robot 'starfish': no firmware templates yet for the device " \
        "kinds dc_motor"


def test_every_kind_is_a_board_section_on_its_roles():
    for kind in COMPONENTS:
        assert kind.section in Board.model_fields, kind.kind
        assert component(kind.section) is kind
        for role in kind.roles:
            assert kind.section in ROLE_SECTIONS[role]
        for role in set(ROLE_SECTIONS) - set(kind.roles):
            assert kind.section not in ROLE_SECTIONS[role]
    assert [k.kind for k in COMPONENTS] == ["servo", "pressure_sensor", "analog_mux", "motion",
                                           "dc_motor", "optical_flow", "omni_base"]
    with pytest.raises(KeyError):
        component("wheels")


def test_papaman_keeps_its_roles_and_registers(robot):
    assert ROLE_SECTIONS["actuator"] == {"servos", "sync", "figure"}      # figure: the HMI's
    assert ROLE_SECTIONS["sensor"] == {"sensors", "mux"}            # mux: papaman-avr's 74HC4051
    assert robot.actuator.register_count == 24 and robot.sensor_board.register_count == 16
