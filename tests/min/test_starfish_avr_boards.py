"""STARFISH on ATmega328P boards (issue 24, item 2 for STARFISH's kinds): boards/starfish-avr
validates, ``esair check`` says which wheel gets which hardware PWM unit of the part, and
every rule an AVR board can break is reported word for word with ``file:line:col``
(tests/fixtures/bad_starfish_avr/<case>/: a copy of boards/starfish-avr with one change,
named on the changed file's first line). No toolchain needed: the builds and simulator
runs are in test_starfish_avr.py."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest
from click.testing import CliRunner

from esair_min.avr.starfish_simavr import CentralSetup, script_commands
from esair_min.cli import main
from esair_min.codegen import generate_robot, render_robot
from esair_min.components.omni_base.harness import run_script
from esair_min.components.omni_base.sim_replay import FlowChange
from esair_min.errors import ProtocolError
from esair_min.components.dc_motor import pwm_units
from esair_min.model.validate import load_robot
from tests.support.bad_boards import assert_refused, cases

ROOT = Path(__file__).resolve().parents[2]
BAD = Path("tests/fixtures/bad_starfish_avr")

EXPECTED = {
    "drive_clock": "tests/fixtures/bad_starfish_avr/drive_clock/drive.yaml:15:13: the ATmega328P drive port's Timer2 cannot interrupt exactly 10000 times a second at 7372800 Hz (the software PWM step and the control tick); use a clock_hz it can divide down to that, e.g. 8000000, 16000000 or 20000000",  # noqa: E501
    "baud_115200": "tests/fixtures/bad_starfish_avr/baud_115200/central.yaml:16:9: baud 115200 cannot be made at 16000000 Hz within 2 %: best is UBRR0 16 with U2X0=1 (117647 baud, +2.12 %)",  # noqa: E501
    "flow_on_crystal_pin": "tests/fixtures/bad_starfish_avr/flow_on_crystal_pin/central.yaml:33:49: pin PB6 of flow sensor 'flow_right' SDIO does not exist on the atmega328p (PB0..PB5, PC0..PC5, PD0..PD7 (PB6/PB7 hold the crystal))",  # noqa: E501
    "no_ccp": "tests/fixtures/bad_starfish_avr/no_ccp/drive.yaml:25:62: motor 'right': the ATmega328P has no CCP1; its hardware PWM outputs are OC0A (PD6), OC0B (PD5), OC1A (PB1), OC1B (PB2), or use pwm: software",  # noqa: E501
    "oc2_taken": "tests/fixtures/bad_starfish_avr/oc2_taken/drive.yaml:25:62: motor 'right': OC2B (PD3) is on Timer2, which the ATmega328P drive port takes for its interrupt (software PWM and the control tick); use OC0A (PD6), OC0B (PD5), OC1A (PB1), OC1B (PB2) or pwm: software",  # noqa: E501
    "oc_wrong_pin": "tests/fixtures/bad_starfish_avr/oc_wrong_pin/drive.yaml:25:38: motor 'right': OC1A drives pin PB1 on the atmega328p, not PB2; set pwm_pin: PB1 or pwm: software",  # noqa: E501
}


def test_every_fixture_has_its_message():
    assert cases(BAD) == sorted(EXPECTED)


@pytest.mark.parametrize("case", sorted(EXPECTED))
def test_bad_starfish_avr_message(case):
    assert_refused(BAD / case, EXPECTED[case])


def test_esair_check_starfish_avr_prints_clock_timers_and_pwm_units():
    result = CliRunner().invoke(main, ["check", "starfish-avr"])
    assert result.exit_code == 0, result.output
    assert result.output.splitlines() == [
        "robot 'starfish-avr': 2 boards (central [central], drive [drive])",
        "  servos: 0, sensors: 0, commands: 0, motions: 0, reactions: 0",   # no empty "()"
        "  tick: 10.0000 ms (Timer1 CTC, prescale 8, OCR1A 19999 at 16000000 Hz)",
        "  UART: 38400 baud, UBRR0 25 U2X0=0, error +0.16 %",
        "  I2C: 100000 Hz, TWBR 72 TWPS 0",
        "  flow sensors: flow_left at (0, 80) mm, SCLK PD4 SDIO PD5, flow_right at (0, -80) "
        "mm, SCLK PD6 SDIO PD7",
        "  base: omni, watchdog 500 ms, |v| <= 500 mm/s, |omega| <= 3000 mrad/s",
        "  motors: front OC0A (PD6), left OC0B (PD5), right OC1A (PB1)",
        "ok",
    ]


def test_pwm_units_follow_the_part():
    avr = load_robot(ROOT / "boards" / "starfish-avr").board("drive")
    assert pwm_units(avr.motors, avr.spec) == {"front": "oc0a", "left": "oc0b", "right": "oc1a"}
    # the same pins on the PIC would be software PWM; OC2B's pin PD3 too on the AVR
    moved = avr.model_copy(update={"motors": (avr.motors[0].model_copy(update={"pwm_pin": "PD3"}),)})
    assert pwm_units(moved.motors, avr.spec) == {"front": "software"}


def test_the_avr_ports_render_the_registers_the_models_give(tmp_path):
    files = render_robot(load_robot(ROOT / "boards" / "starfish-avr"))
    assert not any("/ports/pic18f452/" in name for name in files)
    drive = files["drive/ports/atmega328p/hal_avr.c"]
    assert "OCR2A = 199u;" in drive and "TCCR2B = 0x02u;" in drive    # 10 kHz: 16 MHz / 8 / 200
    assert "TCCR0A = 0xA1u;" in drive and "TCCR1A = 0x81u;" in drive  # OC0A+OC0B, OC1A; WGMn0
    central = files["central/ports/atmega328p/hal_avr.c"]
    assert "#define ES_OCR1A 19999u" in central and "#define ES_UBRR 25u" in central
    assert "_delay_us(100);" in central


HOST_SCRIPT = """rx v
rx V+0200+0000+0000
flow 0 10 -3 88
tick 2
rx O
tick 60
rx O
rx x
"""


def test_the_host_c_of_the_avr_boards_equals_the_python_core(tmp_path):
    """The fourth column's anchor: the AVR boards' generated host port (the same core) and
    the Python core give the same trace (test_starfish_avr.py compares the AVR build with
    the Python core)."""
    robot = load_robot(ROOT / "boards" / "starfish-avr")
    generate_robot(robot, tmp_path)
    subprocess.run(["make", "-s", "host"], cwd=tmp_path / "central", check=True)
    script = tmp_path / "script.txt"
    script.write_text(HOST_SCRIPT)
    run = subprocess.run([str(tmp_path / "central" / "firmware_host"), str(script)],
                         capture_output=True, text=True, timeout=60, check=True)
    python = run_script(robot, HOST_SCRIPT)
    assert run.stdout.splitlines() == python
    assert "TX !W watchdog stop" in python and "TX OK n=2 a=10,-3,88 b=0,0,0" in python


@pytest.mark.parametrize(("line", "message"), [
    ("bogus 1", "stimulus line 2: 'bogus 1' is not rx TEXT, raw HH ..., tick N, floor S 0|1 or "
                "flow S DX DY SQUAL"),
    ("flow 0 200 0 90", "stimulus line 2: 'flow 0 200 0 90' is not rx TEXT, raw HH ..., tick N, "
                        "floor S 0|1 or flow S DX DY SQUAL"),
    ("floor 2 1", "stimulus line 2: flow sensor 2: there are 2 flow sensors"),
    ("tick 0", "stimulus line 2: 'tick 0' is not rx TEXT, raw HH ..., tick N, floor S 0|1 or "
               "flow S DX DY SQUAL"),
])
def test_the_simavr_stimulus_refuses_what_it_cannot_run(line, message):
    setup = CentralSetup.from_robot(load_robot(ROOT / "boards" / "starfish-avr"))
    with pytest.raises(ProtocolError) as exc:
        script_commands(setup, f"rx v\n{line}\n")
    assert str(exc.value) == message


def test_the_simavr_stimulus_becomes_driver_commands_at_line_rate():
    setup = CentralSetup.from_robot(load_robot(ROOT / "boards" / "starfish-avr"))
    assert setup.byte_cycles == 4160 and setup.tick_cycles == 160_000   # 38461.5 baud, 10 ms
    lines, changes, end = script_commands(setup, "rx O\nflow 1 -2 3 90\ntick 1\n")
    assert lines == ["run 40000", "rx 44160 79", "rx 48320 13", "rx 52480 10",
                     "flowfloor 1 -1", "flowreg 1 3 254", "flowreg 1 2 3", "flowreg 1 4 90",
                     "run 200000", "run 1800000"]
    assert changes == [FlowChange(40000, 1, motion=(-2, 3, 90))] and end == 1_800_000
