"""The EEPROM motion image: layout, CRC, parse checks, Intel HEX round trip, CLI."""

from __future__ import annotations

import dataclasses
import struct
from pathlib import Path

import pytest
from click.testing import CliRunner

from esair_min.cli import main
from esair_min.errors import ImageError
from esair_min.core.image import (build_image, crc16_ccitt, header_of, image_summary, parse_image,
                             read_hex, write_hex)
from esair_min.model.board import Frame
from esair_min.model.robot import Robot
from esair_min.model.validate import load_robot

ROOT = Path(__file__).resolve().parents[2]
PAPAMAN = load_robot(ROOT / "boards" / "papaman")


def with_motion_frame(robot: Robot, motion: str, frame: Frame) -> Robot:
    motions = tuple(m.model_copy(update={"frames": m.frames[:-1] + (frame,)})
                    if m.name == motion else m for m in robot.motions)
    boards = tuple(b.model_copy(update={"motions": motions}) if b.role == "central" else b
                   for b in robot.boards)
    return dataclasses.replace(robot, boards=boards)


def with_eeprom_size(robot: Robot, size: int) -> Robot:
    devices = tuple(d.model_copy(update={"size_bytes": size}) if d.kind == "eeprom" else d
                    for d in robot.central.i2c.devices)
    i2c = robot.central.i2c.model_copy(update={"devices": devices})
    boards = tuple(b.model_copy(update={"i2c": i2c}) if b.role == "central" else b
                   for b in robot.boards)
    return dataclasses.replace(robot, boards=boards)


def test_crc_check_value():
    assert crc16_ccitt(b"123456789") == 0x29B1
    assert crc16_ccitt(b"") == 0xFFFF
    assert crc16_ccitt(b"56789", crc16_ccitt(b"1234")) == 0x29B1


def test_papaman_image_layout():
    image = build_image(PAPAMAN)
    assert len(image) == 8 + 30 + 43 * 24 == 1070
    assert image[:4] == b"EM\x02\x05"
    length, crc = struct.unpack_from("<HH", image, 4)
    assert length == 1070 and crc == crc16_ccitt(image[8:])
    # directory: number, frames, delay, servos, offset
    entries = [struct.unpack_from("<BBBBH", image, 8 + 6 * i) for i in range(5)]
    assert entries == [(0, 1, 10, 12, 38), (1, 3, 20, 12, 62), (2, 4, 25, 12, 134),
                       (3, 32, 1, 12, 230), (4, 3, 2, 12, 998)]
    # sit's first frame: 90 -> (90, 0 + 30), 105 -> (5, 1 + 30)
    assert image[62:66] == bytes([90, 30, 90, 30])
    assert image[66:68] == bytes([5, 31])


def test_parse_round_trip_through_intel_hex(tmp_path):
    image = build_image(PAPAMAN)
    path = tmp_path / "p.hex"
    write_hex(image, path)
    data = read_hex(path, 32768)
    assert len(data) == 32768 and data[:1070] == image and set(data[1070:]) == {0xFF}
    parsed = parse_image(data, PAPAMAN)
    assert parsed.header == header_of(image)
    assert parsed.frame_bytes == 24 and parsed.frame_count == 43
    for m in PAPAMAN.motions:
        pm = parsed.motion(m.number)
        assert pm.delay_ticks == m.delay_ticks
        assert pm.poses() == tuple(tuple(zip(f.angles, f.speeds())) for f in m.frames)
    assert parse_image(image) == parsed          # without the robot: frame size inferred
    assert parsed.motion(42) is None


def corrupt(offset: int, value: int, fix_crc: bool = True) -> bytes:
    image = bytearray(build_image(PAPAMAN))
    image[offset] = value
    if fix_crc:
        image[6:8] = crc16_ccitt(image[8:]).to_bytes(2, "little")
    return bytes(image)


@pytest.mark.parametrize("data, message", ids=range(12), argvalues=[
    (b"EM\x01", "image is 3 bytes, shorter than its 8-byte header"),
    (corrupt(0, ord("X")), "bad magic b'XM' (expected b'EM')"),
    (corrupt(2, 1), "unsupported image version 1 (expected 2)"),
    (corrupt(4, 0x2F), "image length 1071 does not fit the 1070 bytes given and a "
     "5-motion directory"),
    (corrupt(4, 0x0A), "CRC mismatch: header says 0x"),      # length 1034: CRC of less
    (corrupt(100, 7, fix_crc=False), "CRC mismatch: header says 0x2C20, bytes give 0x"),
    (corrupt(8, 1), "directory: motion number 1 out of order or above 99"),
    (corrupt(9 + 6, 0), "directory: motion 1 has frames 0, delay 20, servos 12"),
    (corrupt(11, 1), "directory: motion 0 has frames 1, delay 10, servos 1"),
    (corrupt(12, 39), "directory: motion 0 at offset 39, expected 38"),
    (corrupt(38, 100), "motion 0 frame 0: servo 0 low byte 100 is not below 100"),
    (corrupt(9, 2), "1032 frame bytes do not hold 44 frames"),
])
def test_parse_errors(data, message):
    """Each corruption is named (ids would be the whole image: see the messages)."""
    with pytest.raises(ImageError) as e:
        parse_image(data)
    assert str(e.value).startswith(message)


def test_parse_with_robot_checks_limits_and_size():
    data = corrupt(38, 30)                         # stand frame, servo a: 30 degrees
    assert parse_image(data).motion(0).poses()[0][0] == (30, 2)
    with pytest.raises(ImageError) as e:
        parse_image(data, PAPAMAN)
    assert str(e.value) == ("motion 0 frame 0: angle 30 for servo 'l_hip_yaw' is outside "
                            "its limits 60..120")


def test_build_refuses_frames_outside_limits_and_overflow():
    bad = with_motion_frame(PAPAMAN, "sit", Frame(angles=(130,) + (90,) * 11, speed=3))
    with pytest.raises(ImageError) as e:
        build_image(bad)
    assert str(e.value) == ("motion 'sit' frame 2: angle 130 for servo 'l_hip_yaw' is "
                            "outside its limits 60..120")
    bad = with_motion_frame(PAPAMAN, "sit", Frame(angles=(90,) * 12, speed=25))
    assert build_image(bad)                         # 0 + 250 fits
    short = with_motion_frame(PAPAMAN, "stand", Frame(angles=(90,) * 11))
    with pytest.raises(ImageError) as e:
        build_image(short)
    assert str(e.value) == "motion 'stand' frame 0: 11 angles for 12 servos"


def test_build_refuses_an_overflowing_pair():
    servos = tuple(s.model_copy(update={"max_angle": 700}) if s.index == 0 else s
                   for s in PAPAMAN.actuator.servos)
    boards = tuple(b.model_copy(update={"servos": servos}) if b.role == "actuator" else b
                   for b in PAPAMAN.boards)
    robot = dataclasses.replace(PAPAMAN, boards=boards)
    robot = with_motion_frame(robot, "stand", Frame(angles=(600,) + (90,) * 11, speed=25))
    with pytest.raises(ImageError) as e:
        build_image(robot)
    assert str(e.value) == ("motion 'stand' frame 0: speed 25 with angle 600 encodes to "
                            "high byte 256, more than 255")


def test_build_refuses_an_image_larger_than_the_eeprom():
    with pytest.raises(ImageError) as e:
        build_image(with_eeprom_size(PAPAMAN, 1024))
    assert str(e.value) == "the motion image needs 1070 bytes but EEPROM 'motion_store' has 1024"


def test_hex_errors(tmp_path):
    with pytest.raises(ImageError) as e:
        read_hex(tmp_path / "none.hex", 16)
    assert str(e.value) == f"cannot read {tmp_path / 'none.hex'}: No such file or directory"
    bad = tmp_path / "bad.hex"
    bad.write_text(":zz\n")
    with pytest.raises(ImageError) as e:
        read_hex(bad, 16)
    assert str(e.value).startswith(f"{bad}: not a valid Intel HEX file (")
    big = tmp_path / "big.hex"
    write_hex(bytes(20), big)
    with pytest.raises(ImageError) as e:
        read_hex(big, 16)
    assert str(e.value) == f"{big}: data at address 0x13, beyond the 16-byte EEPROM"
    assert read_hex(big, 24) == bytes(20) + b"\xff" * 4
    with pytest.raises(ImageError) as e:
        write_hex(b"\x00", tmp_path / "no" / "x.hex")
    assert str(e.value) == f"cannot write {tmp_path / 'no' / 'x.hex'}: No such file or directory"


def test_summary():
    assert image_summary(PAPAMAN, build_image(PAPAMAN)) == \
        "papaman: 5 motions, 43 frames, 1070 of 32768 bytes used, CRC 0x2C20"


def test_cli_eeprom(tmp_path):
    runner = CliRunner()
    out = tmp_path / "papaman-eeprom.hex"
    res = runner.invoke(main, ["eeprom", str(ROOT / "boards" / "papaman"), "-o", str(out)])
    assert res.exit_code == 0, res.output
    assert res.output == ("papaman: 5 motions, 43 frames, 1070 of 32768 bytes used, "
                          f"CRC 0x2C20 -> {out}\n")
    assert read_hex(out, 32768)[:1070] == build_image(PAPAMAN)
    raw = tmp_path / "p.bin"
    res = runner.invoke(main, ["eeprom", "papaman", "-o", str(raw), "--bin"])
    assert res.exit_code == 0 and raw.read_bytes() == build_image(PAPAMAN)
    res = runner.invoke(main, ["eeprom", "papaman", "-o", str(tmp_path / "no" / "x.bin"),
                               "--bin"])
    assert res.exit_code == 1
    assert res.output == (f"error: cannot write {tmp_path / 'no' / 'x.bin'}: "
                          "No such file or directory\n")


def test_build_refuses_an_image_beyond_16_bits():
    dance = PAPAMAN.motion("dance")
    motions = tuple(dance.model_copy(update={"name": f"m{i}", "number": i}) for i in range(90))
    robot = with_eeprom_size(PAPAMAN, 131072)
    boards = tuple(b.model_copy(update={"motions": motions, "reactions": ()})
                   if b.role == "central" else b for b in robot.boards)
    robot = dataclasses.replace(robot, boards=boards)
    with pytest.raises(ImageError) as e:
        build_image(robot)
    assert str(e.value) == "the motion image needs 69668 bytes, more than 65535"
