"""Pure protocol functions: reply table, checksum, pair encoding, line builders, replies."""

from __future__ import annotations

import pytest

from esair_min.errors import ProtocolError
from esair_min.core.protocol import (ERROR_LINE, ERROR_TEXT, NOTICE_LINE, Code, add_checksum,
                                angle_code, decode_pair, encode_angles, encode_motor,
                                encode_pair, encode_play, encode_sensors, encode_speeds,
                                encode_stand, encode_stop, encode_version, frame_line,
                                ok_line, parse_reply, reaction_line, ready_line,
                                version_data, xor_checksum)

# The table of docs/protocol.md, copied literally.
DOC_TABLE = """
E01 unknown command
E02 line too long
E03 bad argument
E04 outside limits
E05 speed/angle overflow
E06 bad checksum
E07 busy
E08 no such motion
E09 motion image invalid
E10 no answer on i2c
E11 checksum required
E12 input overrun
E13 bad character
""".strip().splitlines()


def test_error_table_is_the_documented_one():
    assert [ERROR_TEXT[c] for c in sorted(Code)] == DOC_TABLE
    for c in Code:
        assert ERROR_TEXT[c].startswith(f"E{c.value:02d} ")
        assert ERROR_LINE[c] == ERROR_TEXT[c].encode() + b"\r\n"
        assert NOTICE_LINE[c] == b"!" + ERROR_TEXT[c].encode() + b"\r\n"


def test_fixed_lines():
    assert ready_line(True, 0x2C20) == b"!READY esair-min/1 image=ok crc=2C20\r\n"
    assert ready_line(True, 0xAB, "0123abcd") == \
        b"!READY esair-min/1 image=ok crc=00AB build=0123abcd\r\n"
    assert ready_line(False, 0x2C20, "0123abcd") == \
        b"!READY esair-min/1 image=bad build=0123abcd\r\n"
    assert reaction_line("auto_balance") == b"!R auto_balance\r\n"
    assert ok_line() == b"OK\r\n"
    assert ok_line("1,2") == b"OK 1,2\r\n"
    assert version_data(12, 8, 5, True, False, crc=0x2C20) == \
        "esair-min/1 servos=12 sensors=8 motions=5 image=ok crc=2C20 checksum=off"
    assert version_data(3, 0, 0, False, True, "00ff00ff", 0x2C20, "0123abcd") == \
        "esair-min/1 servos=3 sensors=0 motions=0 image=bad checksum=on build=0123abcd " \
        "id=00ff00ff"


def test_checksum_examples_of_the_doc():
    assert add_checksum("t") == "t*74"
    assert add_checksum("PLY03") == "PLY03*46"
    assert xor_checksum("") == 0
    assert xor_checksum(b"\x01\x02") == 3
    assert add_checksum("a") == "a*61"
    assert frame_line("t", checksum=True) == b"t*74\r\n"
    assert frame_line("x") == b"x\r\n"


def test_pair_formula():
    assert encode_pair(90, 2) == (90, 20)
    assert encode_pair(135, 3) == (35, 31)
    assert encode_pair(999, 24) == (99, 249)
    assert encode_pair(599, 25) == (99, 255)
    assert decode_pair(35, 31) == (135, 3)
    assert decode_pair(99, 255) == (599, 25)


@pytest.mark.parametrize("call, args, message", [
    (encode_pair, (600, 25), "speed 25 with angle 600 encodes to high byte 256, more than 255"),
    (encode_pair, (1000, 0), "angle 1000 is outside 0..999"),
    (encode_pair, (10, 26), "speed 26 is outside 0..25"),
    (decode_pair, (100, 3), "pair (100, 3) is not a servo encoding"),
])
def test_pair_errors(call, args, message):
    with pytest.raises(ProtocolError) as e:
        call(*args)
    assert str(e.value) == message


def test_command_builders():
    assert encode_motor(0, 1, 100) == "oab100"
    assert encode_motor(11, 25, 7) == "olz007"
    assert encode_play(3) == "PLY03"
    assert encode_speeds([0, 25, 2]) == "a000025002"
    assert encode_angles([0, 180, None, 90]) == "c0l.N"
    assert angle_code(3) == "1"
    assert (encode_stand(), encode_version(), encode_sensors(), encode_stop()) == \
        ("t", "v", "s", "x")
    assert encode_play(7, prefix="GO") == "GO07"


@pytest.mark.parametrize("call, message", [
    (lambda: encode_motor(26, 0, 90), "motor 26 is outside 0..25"),
    (lambda: encode_motor(0, 26, 90), "speed 26 is outside 0..25"),
    (lambda: encode_motor(0, 0, 1000), "angle 1000 is outside 0..999"),
    (lambda: encode_play(100), "motion number 100 is outside 0..99"),
    (lambda: encode_speeds([3, 26]), "speed 26 is outside 0..25"),
    (lambda: encode_angles([91]), "angle 91 is not a multiple of 3 in 0..180"),
    (lambda: angle_code(183), "angle 183 is not a multiple of 3 in 0..180"),
])
def test_builder_errors(call, message):
    with pytest.raises(ProtocolError) as e:
        call()
    assert str(e.value) == message


def test_parse_replies():
    r = parse_reply(b"OK\r\n")
    assert (r.kind, r.code, r.data, r.counts) == ("ok", None, "", True)
    r = parse_reply("OK 512,498")
    assert (r.kind, r.data) == ("ok", "512,498")
    r = parse_reply(b"E07 busy\r\n")
    assert (r.kind, r.code, r.counts) == ("error", Code.BUSY, True)
    r = parse_reply(b"!E10 no answer on i2c\r\n")
    assert (r.kind, r.code, r.counts) == ("notice", Code.NO_ANSWER, False)
    r = parse_reply("!R auto_balance")
    assert (r.kind, r.code, r.data) == ("notice", None, "R auto_balance")
    for c in Code:
        assert parse_reply(ERROR_LINE[c]).code == c
    with pytest.raises(ProtocolError) as e:
        parse_reply("E99 what")
    assert str(e.value) == "not a reply line: 'E99 what'"
