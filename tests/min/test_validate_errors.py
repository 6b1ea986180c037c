"""Every bad board configuration gives exact `path:line:col: message` lines: one for
each error of the robot, sorted by file, line and column (the validator collects them
all: docs/board-format.md, "Errors").

Each case is a fixture under tests/fixtures/bad/<case>/: a robot folder (usually a copy
of boards/papaman with one change, marked by a comment on the changed file's first
line) or a folder holding a single broken file. A change that breaks several rules
expects a tuple of lines. Paths are relative: the tests run from the repository root,
as a user would.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from esair_min.cli import main
from esair_min.errors import ConfigError
from esair_min.model.validate import load_robot
from esair_min.config.yamlload import MAX_FILE_BYTES, load_yaml

ROOT = Path(__file__).resolve().parents[2]
BAD = Path("tests/fixtures/bad")

EXPECTED = {
    "address_out_of_range":
        "tests/fixtures/bad/address_out_of_range/sensor.yaml:13:12: 'address' must be at most 119 (0x77), not 160 (0xA0)",
    "alias_bomb":
        "tests/fixtures/bad/alias_bomb/central.yaml:7:4: aliases expand this document to more than 100000 values (a billion-laughs style alias bomb?); write the values out instead of nesting '*' aliases",
    "alias_recursive":
        "tests/fixtures/bad/alias_recursive/central.yaml:4:10: this list or mapping contains a '*' alias of itself (endless recursion); remove that alias",
    "ambiguous_commands":
        "tests/fixtures/bad/ambiguous_commands/central.yaml:37:29: command 'stop' (prefix 't', 1-char lines) is ambiguous with 'stand' (prefix 't', 1-char lines): one line would match both; change one prefix",
    "ambiguous_play":
        "tests/fixtures/bad/ambiguous_play/central.yaml:38:29: command 'sit' (prefix 'PLY01', 5-char lines) is ambiguous with 'play' (prefix 'PLY', 5-char lines): one line would match both; change one prefix",
    "bus_too_slow":
        "tests/fixtures/bad/bus_too_slow/central.yaml:21:13: I2C at 100000 Hz is too slow for motion 'dance' (a frame every tick, 6.00 ms): frame write 236 + next frame read 255 + sensor poll 174 bit times = 6.65 ms, 7.65 ms with the PIC master's overhead; use delay_ticks: 2 for motion 'dance' or a longer tick",
    "bad_device_kind":
        "tests/fixtures/bad/bad_device_kind/central.yaml:23:14: 'kind' must be 'eeprom' or 'board', not text 'eprom' (did you mean 'eeprom'?)",
    "bad_name":
        "tests/fixtures/bad/bad_name/central.yaml:58:11: 'name' must be a lower-case name (a-z, 0-9, _; at most 24 characters, starting with a letter), not text 'Sit'",
    "bad_role":
        "tests/fixtures/bad/bad_role/central.yaml:7:7: 'role' must be one of 'central', 'actuator', 'sensor' or 'drive', not text 'centrl' (did you mean 'central'?)",
    "baud_error":
        'tests/fixtures/bad/baud_error/central.yaml:13:9: baud 230400 cannot be made at 20000000 Hz within 2 %: best is SPBRG 4 with BRGH=1 (250000 baud, +8.51 %)',
    "binary_junk":
        'tests/fixtures/bad/binary_junk/central.yaml:1:1: not a text file (invalid UTF-8 at byte 0); a board file is UTF-8 YAML',
    "binary_nul":
        'tests/fixtures/bad/binary_nul/central.yaml:3:17: control character U+0000 is not allowed in a YAML file (is this a binary file?)',
    "bool_type":
        "tests/fixtures/bad/bool_type/central.yaml:14:21: 'require_checksum' must be true or false, not text 'maybe'",
    "command_needs_sensor_board": (
        "tests/fixtures/bad/command_needs_sensor_board/central.yaml:35:42: command 'sensors' (action sensors) needs a sensor board in this robot",
        "tests/fixtures/bad/command_needs_sensor_board/central.yaml:45:15: reaction 'auto_balance': no sensor group 'left_foot' (groups: none)",
        "tests/fixtures/bad/command_needs_sensor_board/central.yaml:45:26: reaction 'auto_balance': no sensor group 'right_foot' (groups: none)",
    ),
    "command_too_long":
        "tests/fixtures/bad/command_too_long/central.yaml:33:29: command 'speeds' lines are 44 chars; with a 3-char checksum they exceed the 40-char line limit",
    "deep_nesting":
        'tests/fixtures/bad/deep_nesting/central.yaml:1:1: nested too deeply to read (more than 32 levels are never needed in a board file)',
    "dir_as_file":
        'tests/fixtures/bad/dir_as_file/extra.yaml:1:1: is a folder, but a board file (YAML) was expected here; rename or move it',
    "duplicate_board_name": (
        "tests/fixtures/bad/duplicate_board_name/sensor2.yaml:4:8: two files describe board 'sensor' (the other is tests/fixtures/bad/duplicate_board_name/sensor.yaml)",
        "tests/fixtures/bad/duplicate_board_name/sensor2.yaml:5:7: a robot has one sensor board, and board 'sensor' (tests/fixtures/bad/duplicate_board_name/sensor.yaml) already is one; change one 'role'",
    ),
    "duplicate_command_name":
        "tests/fixtures/bad/duplicate_command_name/central.yaml:38:12: command name 'play' is already used at line 32; each command needs its own name",
    "duplicate_device_name":
        "tests/fixtures/bad/duplicate_device_name/central.yaml:25:27: device name 'servos' is already used at line 24; each device needs its own name",
    "duplicate_key":
        "tests/fixtures/bad/duplicate_key/central.yaml:14:3: duplicate key 'baud' (first given at line 13); keep only one of them",
    "duplicate_motion_number":
        'tests/fixtures/bad/duplicate_motion_number/central.yaml:66:13: motion number 1 is already used at line 59; each motion needs its own number',
    "duplicate_sensor_channel":
        'tests/fixtures/bad/duplicate_sensor_channel/sensor.yaml:16:33: sensor channel 0 is already used at line 15; each sensor needs its own channel',
    "duplicate_servo_name":
        "tests/fixtures/bad/duplicate_servo_name/actuator.yaml:21:12: servo name 'l_hip_yaw' is already used at line 20; each servo needs its own name",
    "eeprom_address_bytes":
        'tests/fixtures/bad/eeprom_address_bytes/central.yaml:23:91: a 1-byte memory address reaches 256 bytes, but the motion image needs 1070; use address_bytes: 2',
    "eeprom_too_small":
        "tests/fixtures/bad/eeprom_too_small/central.yaml:23:69: the motion image needs 1070 bytes but EEPROM 'motion_store' has 1024 (46 bytes over); use a larger EEPROM or fewer frames",
    "empty_file":
        'tests/fixtures/bad/empty_file/central.yaml:1:1: file is empty, expected a board description (board:, role:, i2c:, ...)',
    "empty_folder":
        'tests/fixtures/bad/empty_folder:1:1: no board files (*.yaml) in this folder',
    "empty_section":
        "tests/fixtures/bad/empty_section/actuator.yaml:16:1: 'sync' is empty, but an actuator board needs it",
    "empty_value":
        "tests/fixtures/bad/empty_value/actuator.yaml:20:73: 'max_angle' has no value; give it one or remove the key",
    "frame_angle_count":
        "tests/fixtures/bad/frame_angle_count/central.yaml:62:18: motion 'sit' frame 0: 11 angles given, the robot has 12 servos",
    "frame_outside_limits":
        "tests/fixtures/bad/frame_outside_limits/central.yaml:62:37: motion 'sit' frame 0: angle 170 for servo 'l_ankle_pitch' is outside its limits 40..140",
    "frame_speed_count":
        "tests/fixtures/bad/frame_speed_count/central.yaml:113:77: motion 'balance' frame 0: 2 speeds given, the robot has 12 servos",
    "i2c_collision":
        "tests/fixtures/bad/i2c_collision/central.yaml:25:57: I2C address 0x50 of 'feet' collides with 'motion_store' (line 23); every device on the bus needs its own address",
    "i2c_speed_unreachable": (
        'tests/fixtures/bad/i2c_speed_unreachable/central.yaml:13:9: baud 9600 cannot be made at 1000000 Hz within 2 %: best is SPBRG 6 with BRGH=1 (8929 baud, -6.99 %)',
        'tests/fixtures/bad/i2c_speed_unreachable/central.yaml:21:13: I2C 400000 Hz cannot be made at 1000000 Hz (SSPADD must be 1..127); choose another speed_hz or clock_hz',
        "tests/fixtures/bad/i2c_speed_unreachable/central.yaml:21:13: bus speed 400000 Hz differs from the 100000 Hz of board 'actuator' (tests/fixtures/bad/i2c_speed_unreachable/actuator.yaml:13:13); use speed_hz: 100000",
        "tests/fixtures/bad/i2c_speed_unreachable/central.yaml:21:13: bus speed 400000 Hz differs from the 100000 Hz of board 'sensor' (tests/fixtures/bad/i2c_speed_unreachable/sensor.yaml:11:13); use speed_hz: 100000",
    ),
    "image_over_64k":
        'tests/fixtures/bad/image_over_64k/central.yaml:52:1: the motion image needs 68456 bytes, more than the 65535 its 16-bit offsets reach; use fewer or shorter motions',
    "master_with_address":
        "tests/fixtures/bad/master_with_address/central.yaml:21:3: an I2C master has no own 'address'; remove it",
    "min_above_max_angle":
        "tests/fixtures/bad/min_above_max_angle/actuator.yaml:20:75: servo 'l_hip_yaw': max_angle (120) is below min_angle (130)",
    "missing_device_kind":
        "tests/fixtures/bad/missing_device_kind/central.yaml:23:7: missing required key 'kind' ('eeprom' or 'board')",
    "missing_file":
        'tests/fixtures/bad/missing_file/central.yaml: no such file or folder',
    "missing_key":
        "tests/fixtures/bad/missing_key/actuator.yaml:21:5: missing required key 'pin'",
    "missing_section":
        "tests/fixtures/bad/missing_section/actuator.yaml:6:1: an actuator board needs a 'sync:' section",
    "motion_on_non_play":
        "tests/fixtures/bad/motion_on_non_play/central.yaml:37:48: 'motion' is only for action 'play'; remove it or use action: play",
    "motions_without_eeprom":
        'tests/fixtures/bad/motions_without_eeprom/central.yaml:51:1: motions need an EEPROM: add one to the I2C devices (kind: eeprom)',
    "no_central":
        "tests/fixtures/bad/no_central/actuator.yaml:1:1: no central board in this robot (one board needs 'role: central')",
    "non_string_key":
        "tests/fixtures/bad/non_string_key/central.yaml:4:1: key '9600' must be a name, not an integer",
    "peer_address":
        "tests/fixtures/bad/peer_address/central.yaml:24:57: device 'feet' is at 0x20 here but board 'sensor' answers at 0x21 (tests/fixtures/bad/peer_address/sensor.yaml:13:12); make the two addresses agree",
    "peer_bus_speed": (
        "tests/fixtures/bad/peer_bus_speed/central.yaml:21:13: bus speed 400000 Hz differs from the 100000 Hz of board 'actuator' (tests/fixtures/bad/peer_bus_speed/actuator.yaml:13:13); use speed_hz: 100000",
        "tests/fixtures/bad/peer_bus_speed/central.yaml:21:13: bus speed 400000 Hz differs from the 100000 Hz of board 'sensor' (tests/fixtures/bad/peer_bus_speed/sensor.yaml:11:13); use speed_hz: 100000",
    ),
    "peer_registers":
        "tests/fixtures/bad/peer_registers/central.yaml:24:78: device 'servos' declares 22 registers but board 'actuator' has 24 (2 per servo and per sensor); set registers: 24",
    "pin_not_on_part":
        "tests/fixtures/bad/pin_not_on_part/actuator.yaml:21:43: pin RE5 of servo 'l_hip_roll' does not exist on the pic18f452 (RA0..RA5, RB0..RB7, RC0..RC7, RD0..RD7, RE0..RE2)",
    "pin_twice":
        "tests/fixtures/bad/pin_twice/actuator.yaml:21:43: pin RD0 is used twice: by servo 'l_hip_yaw' and by servo 'l_hip_roll'; give servo 'l_hip_roll' another pin",
    "pin_twice_uart":
        'tests/fixtures/bad/pin_twice_uart/central.yaml:18:8: pin RC6 is used twice: by the UART and by the sync line; give the sync line another pin',
    "pulse_order":
        "tests/fixtures/bad/pulse_order/actuator.yaml:20:148: servo 'l_hip_yaw': pulse_max_us (1000) must be above pulse_min_us (2000)",
    "python_tag":
        "tests/fixtures/bad/python_tag/central.yaml:2:8: cannot read value: unsupported tag 'tag:yaml.org,2002:python/object/apply:os.system' (remove the '!' tag)",
    "reaction_compare_three":
        "tests/fixtures/bad/reaction_compare_three/central.yaml:46:14: 'compare' must have at most 2 items, not 3",
    "reaction_same_group":
        "tests/fixtures/bad/reaction_same_group/central.yaml:46:26: reaction 'auto_balance' compares group 'left_foot' with itself; compare two different groups",
    "root_list":
        'tests/fixtures/bad/root_list/central.yaml:2:1: the file is a list; a board file must be a mapping of keys (board:, role:, i2c:, ...)',
    "root_scalar":
        'tests/fixtures/bad/root_scalar/central.yaml:2:1: the file is a single value; a board file must be a mapping of keys (board:, role:, i2c:, ...)',
    "section_on_wrong_board":
        "tests/fixtures/bad/section_on_wrong_board/actuator.yaml:16:1: 'uart' does not belong on an actuator board (an actuator board may have: figure, servos, sync); remove it, or check 'role: actuator'",
    "sensor_min_above_max":
        "tests/fixtures/bad/sensor_min_above_max/sensor.yaml:19:70: sensor 'r_toe_in': max (100) must be above min (500)",
    "servo_index_gap":
        "tests/fixtures/bad/servo_index_gap/actuator.yaml:32:34: servo 'r_ankle_roll': index 12 leaves a gap; servo indices must run 0..11 and index 11 is missing",
    "slave_as_master":
        'tests/fixtures/bad/slave_as_master/actuator.yaml:13:9: an actuator board must be an I2C slave (mode: slave)',
    "slave_with_devices":
        "tests/fixtures/bad/slave_with_devices/sensor.yaml:14:3: an I2C slave has no 'devices' (only a master talks to devices)",
    "slave_without_address":
        "tests/fixtures/bad/slave_without_address/sensor.yaml:11:3: an I2C slave needs its own 'address' (0x08..0x77)",
    "speed_list_item":
        "tests/fixtures/bad/speed_list_item/central.yaml:113:111: 'speed[11]' must be at most 25, not 40",
    "speed_out_of_range":
        "tests/fixtures/bad/speed_out_of_range/central.yaml:113:77: 'speed' must be at most 25, not 26",
    "speed_overflow_frame":
        "tests/fixtures/bad/speed_overflow_frame/central.yaml:113:106: motion 'balance' frame 0, servo 'r_knee': speed 25 with angle 700 encodes to high byte 257 (angle/100 + 10*speed), more than 255; at this angle use a speed of at most 24",
    "speed_overflow_servo":
        "tests/fixtures/bad/speed_overflow_servo/actuator.yaml:30:112: servo 'r_knee': default speed 25 with angle 700 encodes to high byte 257 (angle/100 + 10*speed), more than 255; at this angle use a speed of at most 24",
    "stand_outside_limits":
        "tests/fixtures/bad/stand_outside_limits/actuator.yaml:20:92: servo 'l_hip_yaw': stand_angle 130 is outside its limits 60..120",
    "tick_30mhz":
        'tests/fixtures/bad/tick_30mhz/central.yaml:16:14: tick period 8.9856 ms cannot be made by Timer2 at 30000000 Hz within 1 %: nearest is 8.7381 ms (prescale 16, PR2 255, postscale 16)',
    "tick_error":
        'tests/fixtures/bad/tick_error/central.yaml:16:14: tick period 40 ms cannot be made by Timer2 at 20000000 Hz within 1 %: nearest is 13.1072 ms (prescale 16, PR2 255, postscale 16)',
    "tick_infinite":
        'tests/fixtures/bad/tick_infinite/central.yaml:16:14: tick period must be a finite number of ms, not inf',
    "two_actuators": (
        "tests/fixtures/bad/two_actuators/sensor.yaml:4:1: an actuator board needs a 'servos:' section",
        "tests/fixtures/bad/two_actuators/sensor.yaml:4:1: an actuator board needs a 'sync:' section",
        "tests/fixtures/bad/two_actuators/sensor.yaml:5:7: a robot has one actuator board, and board 'actuator' (tests/fixtures/bad/two_actuators/actuator.yaml) already is one; change one 'role'",
        "tests/fixtures/bad/two_actuators/sensor.yaml:14:1: 'sensors' does not belong on an actuator board (an actuator board may have: figure, servos, sync); remove it, or check 'role: actuator'",
    ),
    "two_eeproms":
        'tests/fixtures/bad/two_eeproms/central.yaml:22:3: only one EEPROM device is supported; remove the others',
    "two_sensor_boards":
        "tests/fixtures/bad/two_sensor_boards/sensor2.yaml:5:7: a robot has one sensor board, and board 'sensor' (tests/fixtures/bad/two_sensor_boards/sensor.yaml) already is one; change one 'role'",
    "unknown_command_motion":
        "tests/fixtures/bad/unknown_command_motion/central.yaml:38:56: no motion named 'sitt' (did you mean 'sit'?)",
    "unknown_key":
        "tests/fixtures/bad/unknown_key/actuator.yaml:20:79: unknown key 'stand_angel' (did you mean 'stand_angle'?)",
    "unknown_peer_board":
        "tests/fixtures/bad/unknown_peer_board/central.yaml:25:40: no peer board named 'sensr' in this robot (did you mean 'sensor'?)",
    "unknown_reaction_group":
        "tests/fixtures/bad/unknown_reaction_group/central.yaml:46:26: reaction 'auto_balance': no sensor group 'rigt_foot' (did you mean 'right_foot'?) (groups: left_foot, right_foot)",
    "unknown_reaction_motion":
        "tests/fixtures/bad/unknown_reaction_motion/central.yaml:50:13: reaction 'auto_balance': no motion named 'balanse' (did you mean 'balance'?)",
    "unknown_section":
        "tests/fixtures/bad/unknown_section/central.yaml:12:1: unknown key 'uart_' (did you mean 'uart'?)",
    "unreachable_board":
        "tests/fixtures/bad/unreachable_board/sensor.yaml:3:8: board 'sensor' is not among the central board's I2C devices, so nothing can reach it; add it there (kind: board, board: sensor)",
    "wrong_type_angle":
        "tests/fixtures/bad/wrong_type_angle/central.yaml:62:32: 'angles[3]' must be an integer, not text 'ninety'",
    "wrong_type_clock":
        "tests/fixtures/bad/wrong_type_clock/central.yaml:11:13: 'clock_hz' must be an integer, not text '20MHz'",
    "wrong_type_float":
        "tests/fixtures/bad/wrong_type_float/central.yaml:62:27: 'angles[2]' must be an integer, not a number 105.5",
    "wrong_type_i2c":
        "tests/fixtures/bad/wrong_type_i2c/sensor.yaml:10:6: 'i2c' must be a mapping of keys, not text 'slave 0x20'",
    "wrong_type_yes_no":
        "tests/fixtures/bad/wrong_type_yes_no/sensor.yaml:15:43: 'group' must be text, not true (YAML reads unquoted yes/no/on/off/true/false as true/false: quote it)",
    "figure_unknown_servo":
        "tests/fixtures/bad/figure_unknown_servo/actuator.yaml:40:85: figure: left knee: no servo named 'l_kne' on this board (did you mean 'l_knee'?)",
    "figure_servo_twice":
        "tests/fixtures/bad/figure_servo_twice/actuator.yaml:43:53: figure: right ankle_roll: servo 'r_ankle_pitch' already turns the right ankle_pitch",
    "figure_bad_length":
        "tests/fixtures/bad/figure_bad_length/actuator.yaml:38:41: 'thigh' must be greater than 0, not 0",
    "slave_speed": (
        'tests/fixtures/bad/slave_speed/actuator.yaml:14:13: the generated I2C slave runs at 100000 Hz only (at 400000 Hz a byte it takes late could be mistaken for its address); use speed_hz: 100000 on every board',
        'tests/fixtures/bad/slave_speed/sensor.yaml:12:13: the generated I2C slave runs at 100000 Hz only (at 400000 Hz a byte it takes late could be mistaken for its address); use speed_hz: 100000 on every board',
    ),
    "yaml_syntax":
        "tests/fixtures/bad/yaml_syntax/central.yaml:4:6: this '{' starts a mapping that is not closed before line 5; end it with '}'",
    "yaml_tab":
        "tests/fixtures/bad/yaml_tab/central.yaml:5:1: a tab character: YAML indents with spaces only; replace the tab by spaces",
    # The analog multiplexer of a sensor board (issue 24, papaman-avr's eight feet).
    "mux_channel_not_in_package":
        "tests/fixtures/bad/mux_channel_not_in_package/sensor.yaml:18:12: the mux's common output: the ATmega328P in the 28-pin PDIP (Arduino Uno) has no analog channel 6; ADC6 exists in the 32-pin TQFP (Arduino Nano, Pro Mini) and the 32-pad QFN/MLF only: set mcu.package: tqfp, or use another channel",
    "mux_channel_out_of_range":
        "tests/fixtures/bad/mux_channel_out_of_range/sensor.yaml:18:12: 'channel' must be at most 7, not 8",
    "mux_channel_taken":
        "tests/fixtures/bad/mux_channel_taken/sensor.yaml:18:12: pin PC4 is used twice: by I2C and by the mux's common output (ADC4); give the mux's common output (ADC4) another pin",
    "mux_input_out_of_range":
        "tests/fixtures/bad/mux_input_out_of_range/sensor.yaml:29:35: 'mux_input' must be at most 7, not 8",
    "mux_input_twice":
        'tests/fixtures/bad/mux_input_twice/sensor.yaml:25:35: sensor mux_input 2 is already used at line 24; each sensor needs its own mux_input',
    "mux_input_unreachable": (
        "tests/fixtures/bad/mux_input_unreachable/sensor.yaml:26:35: sensor 'r_toe_in': the mux has inputs 0..3 (2 select pins), not 4; add select pins (S0..S2) or use another input",
        "tests/fixtures/bad/mux_input_unreachable/sensor.yaml:27:35: sensor 'r_toe_out': the mux has inputs 0..3 (2 select pins), not 5; add select pins (S0..S2) or use another input",
        "tests/fixtures/bad/mux_input_unreachable/sensor.yaml:28:35: sensor 'r_heel_in': the mux has inputs 0..3 (2 select pins), not 6; add select pins (S0..S2) or use another input",
        "tests/fixtures/bad/mux_input_unreachable/sensor.yaml:29:35: sensor 'r_heel_out': the mux has inputs 0..3 (2 select pins), not 7; add select pins (S0..S2) or use another input",
    ),
    "mux_input_without_mux":
        "tests/fixtures/bad/mux_input_without_mux/sensor.yaml:22:35: sensor 'r_heel_out': mux_input 7 needs a 'mux:' section on this board (its ADC channel and select pins)",
    "mux_select_not_on_part":
        "tests/fixtures/bad/mux_select_not_on_part/sensor.yaml:19:22: pin PB6 of the mux's select S2 does not exist on the atmega328p (PB0..PB5, PC0..PC5, PD0..PD7 (PB6/PB7 hold the crystal))",
    "mux_select_taken":
        "tests/fixtures/bad/mux_select_taken/sensor.yaml:19:22: pin PC5 is used twice: by I2C and by the mux's select S2; give the mux's select S2 another pin",
    "mux_select_twice":
        "tests/fixtures/bad/mux_select_twice/sensor.yaml:19:17: pin PB0 is used twice: by the mux's select S0 and by the mux's select S1; give the mux's select S1 another pin",
    "mux_too_many_selects":
        "tests/fixtures/bad/mux_too_many_selects/sensor.yaml:19:11: 'select' must have at most 3 items, not 4",
    "mux_without_sensor": (
        "tests/fixtures/bad/mux_without_sensor/sensor.yaml:14:1: the mux has no sensor: give sensors a 'mux_input', or remove 'mux:'",
        "tests/fixtures/bad/mux_without_sensor/sensor.yaml:23:33: pin RE2 is used twice: by the mux's common output (AN7) and by sensor 'r_heel_out' (AN7); give sensor 'r_heel_out' (AN7) another pin",
    ),
    "sensor_channel_and_mux_input":
        "tests/fixtures/bad/sensor_channel_and_mux_input/sensor.yaml:29:36: sensor 'r_heel_out' has a 'channel' and a 'mux_input': give one (channel: an ADC channel; mux_input: an input of the board's mux)",
    "sensor_on_mux_channel":
        "tests/fixtures/bad/sensor_on_mux_channel/sensor.yaml:29:33: pin PC0 is used twice: by the mux's common output (ADC0) and by sensor 'r_heel_out' (ADC0); give sensor 'r_heel_out' (ADC0) another pin",
    "sensor_without_channel":
        "tests/fixtures/bad/sensor_without_channel/sensor.yaml:29:5: sensor 'r_heel_out' needs 'channel' (an ADC channel) or 'mux_input' (an input of the board's mux)",
}

#: Cases whose path is not the fixture folder itself.
TARGET = {"missing_file": "central.yaml"}


def target(case: str) -> str:
    path = BAD / case
    if case in TARGET:
        path = path / TARGET[case]
    return str(path)


@pytest.fixture(autouse=True)
def _at_repo_root(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(ROOT)


def lines(case: str) -> tuple[str, ...]:
    expected = EXPECTED[case]
    return (expected,) if isinstance(expected, str) else expected


@pytest.mark.parametrize("case", sorted(EXPECTED))
def test_bad_config_message(case: str) -> None:
    with pytest.raises(ConfigError) as info:
        load_robot(target(case))
    err = info.value
    assert str(err) == "\n".join(lines(case))
    assert [str(e) for e in err.each()] == list(lines(case))
    assert str(err).startswith(f"{err.mark}: {err.message}")     # the first one's
    assert err.mark is not None
    if case == "missing_file":          # no place in a file that does not exist
        assert (err.mark.line, err.mark.col) == (0, 0)
    else:
        assert err.mark.line >= 1 and err.mark.col >= 1


def test_every_fixture_is_asserted() -> None:
    on_disk = {p.name for p in (ROOT / BAD).iterdir() if p.is_dir()}
    assert on_disk == set(EXPECTED)
    assert len(EXPECTED) >= 30


def test_source_robot_of_the_fixtures_is_valid() -> None:
    """The fixtures must fail for their own reason: the source robot itself is valid."""
    robot = load_robot("boards/papaman")
    assert len(robot.servos) == 12


@pytest.mark.parametrize("case", ["yaml_syntax", "alias_bomb", "peer_registers",
                                  "baud_error", "missing_file", "dir_as_file", "binary_nul"])
def test_cli_check_prints_one_error_line(case: str) -> None:
    result = CliRunner().invoke(main, ["check", target(case)])
    assert result.exit_code == 1
    assert result.stdout == ""
    assert result.stderr == f"error: {EXPECTED[case]}\n"
    assert "Traceback" not in result.output


def test_cli_check_missing_robot() -> None:
    result = CliRunner().invoke(main, ["check", "no/such/robot"])
    assert result.exit_code == 1
    assert result.stderr == "error: no/such/robot: no such file or folder\n"


def test_cli_check_real_process() -> None:
    """A real `esair check` process: exit status 1, one line on stderr, no traceback."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, "-m", "esair_min.cli", "check", target("alias_bomb")],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 1
    assert proc.stdout == ""
    assert proc.stderr == f"error: {EXPECTED['alias_bomb']}\n"


# -- cases that need no fixture file ----------------------------------------------------

def test_file_too_large(tmp_path: Path) -> None:
    big = tmp_path / "big.yaml"
    big.write_text("board: x\n" + "# padding\n" * (MAX_FILE_BYTES // 10 + 1))
    with pytest.raises(ConfigError) as info:
        load_yaml(big)
    size = big.stat().st_size
    assert str(info.value) == (f"{big}:1:1: file is {size} bytes, larger than the "
                               f"{MAX_FILE_BYTES} bytes a board file may have")


@pytest.mark.parametrize("text, message", [
    ("---\n", "1:1: file is empty, expected a board description (board:, role:, i2c:, ...)"),
    ("a: 1\n---\nb: 2\n", "2:1: a second YAML document starts here ('---'), but one "
     "document is expected; remove this line and what follows it, or merge the two"),
    ("a: *nowhere\n", "1:4: YAML syntax error: found undefined alias 'nowhere'"),
    ("base: &b {x: 1}\nc:\n  <<: *b\n",
     "3:3: keys must be plain names (no merge keys, lists or mappings as keys)"),
    ("[a, b]: 1\n", "1:1: keys must be plain names (no merge keys, lists or mappings as keys)"),
    ("~: 1\n", "1:1: key '~' must be a name, not an empty value"),
    ("d: 2020-13-45\n",
     "1:4: cannot read value: month must be in 1..12 (quote the value, or remove its '!' tag)"),
    ("d: !!int ten\n", "1:4: cannot read value: invalid literal for int() with base 10: 'ten' "
                       "(quote the value, or remove its '!' tag)"),
    ("d: !!set {a, b}\n",
     "1:4: cannot read value: unsupported tag 'tag:yaml.org,2002:set' (remove the '!' tag)"),
    ("a: &x {b: *x}\n", "1:4: this list or mapping contains a '*' alias of itself "
                        "(endless recursion); remove that alias"),
])
def test_yaml_reader_errors(tmp_path: Path, text: str, message: str) -> None:
    f = tmp_path / "b.yaml"
    f.write_text(text)
    with pytest.raises(ConfigError) as info:
        load_yaml(f)
    assert str(info.value) == f"{f}:{message}"


def test_pipe_where_a_board_file_was_expected(tmp_path: Path) -> None:
    fifo = tmp_path / "central.yaml"
    os.mkfifo(fifo)
    with pytest.raises(ConfigError) as info:
        load_robot(tmp_path)
    assert str(info.value) == (f"{fifo}:1:1: is not a regular file (a device or pipe?); "
                               "a board file is expected here")


def test_unreadable_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    f = tmp_path / "central.yaml"
    f.write_text("board: central\n")

    def refuse(self: Path) -> bytes:
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(Path, "read_bytes", refuse)
    with pytest.raises(ConfigError) as info:
        load_yaml(f)
    assert str(info.value) == f"{f}:1:1: cannot read the file: Permission denied"
