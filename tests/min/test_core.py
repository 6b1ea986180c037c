"""The Python central core over simple devices: every command, reply and error code of
docs/protocol.md (exact bytes), the frame player, the balance reaction, the harness."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from esair_min.core.central import CentralCore
from esair_min.core.devices import Eeprom24, NullBus, RegisterSlave, SimpleBus
from esair_min.errors import ProtocolError
from esair_min.core.stimulus import Rig, main as harness_main, run_script, unescape
from esair_min.core.image import build_image, write_hex
from esair_min.core.protocol import add_checksum
from esair_min.model.robot import Robot
from esair_min.core.trace import TraceWriter, TracingBus, without_marks
from esair_min.model.validate import load_robot
from tests.support.board_lines import ready, version

ROOT = Path(__file__).resolve().parents[2]
PAPAMAN = load_robot(ROOT / "boards" / "papaman")
STAND = "W 10 00" + "5A14" * 12 + " ACK"
OK = b"OK\r\n"


def variant(robot: Robot, role: str, **updates) -> Robot:
    boards = tuple(b.model_copy(update=updates) if b.role == role else b
                   for b in robot.boards)
    return dataclasses.replace(robot, boards=boards)


def with_checksum(robot: Robot = PAPAMAN) -> Robot:
    uart = robot.central.uart.model_copy(update={"require_checksum": True})
    return variant(robot, "central", uart=uart)


def with_servo(robot: Robot, index: int, **updates) -> Robot:
    servos = tuple(s.model_copy(update=updates) if s.index == index else s
                   for s in robot.actuator.servos)
    return variant(robot, "actuator", servos=servos)


def booted(robot: Robot = PAPAMAN) -> Rig:
    rig = Rig(robot)
    rig.boot()
    return rig


def mark(rig: Rig) -> int:
    return len(rig.writer.lines)


def since(rig: Rig, at: int) -> list[str]:
    return rig.writer.lines[at:]


def tx(lines: list[str]) -> list[bytes]:
    return [bytes.fromhex(line[3:]) for line in lines if line.startswith("TX ")]


def say(rig: Rig, text: str | bytes, end: bytes = b"\r\n") -> list[bytes]:
    """Send one line; the lines the board sent back at once."""
    at = mark(rig)
    rig.rx((text.encode() if isinstance(text, str) else text) + end)
    return tx(since(rig, at))


def ticks(rig: Rig, n: int = 1) -> list[str]:
    at = mark(rig)
    rig.tick(n)
    return since(rig, at)


def writes(lines: list[str], addr: str = "10") -> list[str]:
    return [line for line in lines if line.startswith(f"W {addr} ")]


# -- boot ---------------------------------------------------------------------------

def test_boot_checks_the_image_with_the_documented_reads():
    rig = booted()
    lines = rig.writer.lines
    assert lines[0] == "# esair-trace 1"
    assert lines[1] == "R 50 0000 8 " + build_image(PAPAMAN)[:8].hex().upper()
    reads = [line.split()[2:4] for line in lines if line.startswith("R 50")]
    assert reads[1] == ["0008", "32"]
    assert reads[34] == ["0428", "6"]           # 8 + 33*32 = 1064, 6 bytes left of 1070
    # then the directory, one 6-byte entry a read
    assert reads[35:] == [[f"{8 + 6 * i:04X}", "6"] for i in range(5)]
    assert len(reads) == 1 + 34 + 5
    assert tx(lines) == [ready(PAPAMAN)]
    assert rig.core.image_ok


def test_boot_with_a_wrong_header_reads_nothing_more():
    rig = Rig(PAPAMAN)
    rig.eeprom.poke(2, 9)           # format version
    rig.boot()
    assert [line for line in rig.writer.lines if line.startswith("R ")] == \
        ["R 50 0000 8 454D0905" + build_image(PAPAMAN)[4:8].hex().upper()]
    assert tx(rig.writer.lines) == [ready(PAPAMAN, False)]


def test_boot_with_a_silent_eeprom_is_bad():
    rig = Rig(PAPAMAN)
    rig.eeprom.fault = True
    rig.boot()
    assert rig.writer.lines[1:] == ["R 50 0000 8 NACK",
                                    "TX " + ready(PAPAMAN, False).hex().upper()]


def test_boot_resets_the_state():
    rig = booted()
    assert say(rig, "a" + "007" * 12) == [OK]
    say(rig, "PLY03")
    rig.tick(2)
    rig.boot()
    c = rig.core
    assert (c.speeds, c.targets, c.playing, c.ticks) == ((2,) * 12, (90,) * 12, None, 0)


# -- one command each ---------------------------------------------------------------

def test_version():
    assert say(booted(), "v") == [version(PAPAMAN)]
    assert version(PAPAMAN).startswith(b"OK esair-min/1 servos=12 sensors=8 motions=5 "
                                       b"image=ok crc=2C20 checksum=off build=")
    robot = with_checksum()
    assert say(booted(robot), "v*76") == [version(robot, checksum=True)]


def test_stand_is_held_until_the_tick():
    rig = booted()
    assert say(rig, "t") == []
    assert not rig.core.ready()
    assert ticks(rig) == ["T 1", STAND, "TX 4F4B0D0A"]
    assert rig.core.ready()


def test_motor_writes_its_two_registers():
    rig = booted()
    assert say(rig, "oab100") == []
    assert ticks(rig) == ["T 1", "W 10 00000B ACK", "TX 4F4B0D0A"]
    assert say(rig, "olc105") == []
    assert ticks(rig) == ["T 2", "W 10 160515 ACK", "TX 4F4B0D0A"]
    assert rig.core.targets == (100,) + (90,) * 10 + (105,)
    assert rig.core.speeds == (2,) * 12          # o does not change the current speed


@pytest.mark.parametrize("line, reply", [
    ("oaa121", b"E04 outside limits\r\n"),       # servo a: 60..120
    ("oaa059", b"E04 outside limits\r\n"),
    ("oma090", b"E03 bad argument\r\n"),         # motor m = 12: no such servo
    ("oa{090", b"E03 bad argument\r\n"),         # speed not a..z
    ("oaA090", b"E03 bad argument\r\n"),
    ("oaa09x", b"E03 bad argument\r\n"),
    ("oaa0900", b"E03 bad argument\r\n"),        # wrong length
    ("o", b"E03 bad argument\r\n"),
])
def test_motor_refusals(line, reply):
    rig = booted()
    assert say(rig, line) == [reply]
    assert rig.core.ready()
    assert writes(ticks(rig)) == []


def test_overflow_e05_from_motor_and_stand():
    robot = with_servo(PAPAMAN, 0, max_angle=999, stand_angle=700)
    rig = booted(robot)
    assert say(rig, "oaz600") == [b"E05 speed/angle overflow\r\n"]   # 6 + 250 = 256
    assert say(rig, "oaz599") == []                                 # 5 + 250 = 255
    assert ticks(rig)[1:] == ["W 10 0063FF ACK", "TX 4F4B0D0A"]
    assert say(rig, "a" + "025" * 12) == [OK]
    assert say(rig, "t") == [b"E05 speed/angle overflow\r\n"]       # 7 + 250


def test_speeds():
    rig = booted()
    assert say(rig, "a" + "".join(f"{i:03d}" for i in range(12))) == [OK]
    assert rig.core.speeds == tuple(range(12))
    assert say(rig, "t") == []
    assert writes(ticks(rig)) == ["W 10 00" + "".join(f"5A{10 * i:02X}" for i in range(12))
                                  + " ACK"]
    for bad in ("a" + "026" + "000" * 11, "a" + "00x" + "000" * 11, "a" + "000" * 11,
                "a" + "-01" + "000" * 11):
        assert say(rig, bad) == [b"E03 bad argument\r\n"]
    assert rig.core.speeds == tuple(range(12))


def test_angles_with_keep_codes():
    rig = booted()
    assert say(rig, "c" + "T" + "." * 11) == []       # 'T' = 0x54 -> 3*36 = 108
    assert writes(ticks(rig)) == ["W 10 00" + "0815" + "5A14" * 11 + " ACK"]
    assert rig.core.targets == (108,) + (90,) * 11
    assert say(rig, "c" + "0" + "." * 11) == [b"E04 outside limits\r\n"]
    assert say(rig, "c" + "m" + "." * 11) == [b"E03 bad argument\r\n"]   # beyond 'l'
    assert say(rig, "c" + "." * 11) == [b"E03 bad argument\r\n"]


def test_play_and_its_refusals():
    rig = booted()
    assert say(rig, "PLY07") == [b"E08 no such motion\r\n"]
    assert say(rig, "PLYab") == [b"E03 bad argument\r\n"]
    at = mark(rig)
    assert say(rig, "PLY01") == [OK]
    # the directory up to sit's entry, then sit's first frame
    assert [x[:12] for x in since(rig, at)[:3]] == ["R 50 0008 6 ", "R 50 000E 6 ",
                                                    "R 50 003E 24"]
    assert rig.core.playing == 1
    for busy in ("t", "oaa090", "c" + "." * 12, "PLY00", "SIT", "DNC"):
        assert say(rig, busy) == [b"E07 busy\r\n"]
    assert say(rig, "PLY99") == [b"E07 busy\r\n"]               # busy before E08
    assert say(rig, "oma090") == [b"E07 busy\r\n"]              # busy before arguments
    assert say(rig, "a" + "003" * 12) == [OK]
    assert say(rig, "v")[0].startswith(b"OK esair-min/1 ")
    assert say(rig, "s") == [b"OK 0,0,0,0,0,0,0,0\r\n"]
    assert say(rig, "x") == [OK]
    assert rig.core.playing is None
    assert say(rig, "x") == [OK]


def test_fixed_plays():
    rig = booted()
    assert say(rig, "DNC") == [OK]
    assert rig.core.playing == 3
    say(rig, "x")
    assert say(rig, "SIT") == [OK]
    assert rig.core.playing == 1


def test_play_with_a_silent_eeprom_is_e10():
    rig = booted()
    rig.eeprom.fault = True
    assert say(rig, "PLY03") == [b"E10 no answer on i2c\r\n"]
    assert rig.core.playing is None


def test_corrupt_image_is_e09_and_nothing_plays():
    rig = Rig(PAPAMAN)
    rig.eeprom.poke(0x100, 0x00)
    rig.boot()
    assert tx(rig.writer.lines) == [ready(PAPAMAN, False)]
    at = mark(rig)
    assert say(rig, "PLY03") == [b"E09 motion image invalid\r\n"]
    assert say(rig, "DNC") == [b"E09 motion image invalid\r\n"]
    rig.tick(40)
    assert [line for line in since(rig, at) if line[0] in "WR"] == \
        ["R 20 00 16 " + "00" * 16] * 8              # only the reaction's polls


def test_sensors_query_and_e10():
    rig = booted()
    rig.sensor.set_readings([512, 498, 1023, 0, 1, 2, 3, 1000])
    at = mark(rig)
    assert say(rig, "s") == [b"OK 512,498,1023,0,1,2,3,1000\r\n"]
    assert since(rig, at)[0] == "R 20 00 16 0002F201FF030000010002000300E803"
    assert rig.core.last_sensors == (512, 498, 1023, 0, 1, 2, 3, 1000)
    rig.sensor.fault = True
    assert say(rig, "s") == [b"E10 no answer on i2c\r\n"]


def test_actuator_nack_is_e10_and_keeps_targets():
    rig = booted()
    rig.actuator.fault = True
    say(rig, "oaa100")
    assert ticks(rig)[1:] == ["W 10 000001 NACK", "TX " + b"E10 no answer on i2c\r\n".hex().upper()]
    assert rig.core.targets == (90,) * 12


@pytest.mark.parametrize("line, reply", [
    ("q", b"E01 unknown command\r\n"),
    ("PL", b"E01 unknown command\r\n"),
    ("T", b"E01 unknown command\r\n"),
    ("tt", b"E03 bad argument\r\n"),
    ("PLY3", b"E03 bad argument\r\n"),
    ("x" * 41, b"E02 line too long\r\n"),
    ("v" * 40, b"E03 bad argument\r\n"),          # 40 chars is not too long
    ("v\x7f", b"E13 bad character\r\n"),
    ("\x00", b"E13 bad character\r\n"),
    ("v\x80" + "y" * 40, b"E02 line too long\r\n"),  # E02 before E13
    ("t*75", b"E06 bad checksum\r\n"),
    ("PLY03*4f", b"E06 bad checksum\r\n"),       # lower-case hex does not match
    ("t*ZZ", b"E06 bad checksum\r\n"),
    ("*00", b"E01 unknown command\r\n"),
    ("t*7", b"E03 bad argument\r\n"),
    ("zz*" + "%02X" % (ord("z") ^ ord("z")), b"E01 unknown command\r\n"),
])
def test_line_level_errors(line, reply):
    assert say(booted(), line.encode("latin-1")) == [reply]


def test_checksum_accepted_and_required():
    rig = booted()
    assert say(rig, "x*78") == [OK]
    assert say(rig, add_checksum("PLY03")) == [OK]
    rig = booted(with_checksum())
    assert say(rig, "x") == [b"E11 checksum required\r\n"]
    assert say(rig, "x*79") == [b"E06 bad checksum\r\n"]
    assert say(rig, "q") == [b"E11 checksum required\r\n"]   # E11 before matching
    assert say(rig, add_checksum("q")) == [b"E01 unknown command\r\n"]
    assert say(rig, add_checksum("x")) == [OK]
    long_line = "c" + "N" * 12
    assert len(add_checksum(long_line)) == 16
    assert say(rig, add_checksum(long_line)) == []


def test_line_ends():
    rig = booted()
    assert say(rig, "x", b"\r") == [OK]
    assert say(rig, "x", b"\n") == [OK]
    assert say(rig, "x", b"\r\n") == [OK]
    assert say(rig, "x", b"\n\r") == [OK]         # LF CR: two line ends, the second empty
    assert say(rig, b"", b"\r\n\r\n\n\r") == []   # empty lines: no reply
    at = mark(rig)
    rig.rx(b"x\r\nv\nx\r")
    assert len(tx(since(rig, at))) == 3


def test_overrun_while_a_write_is_held():
    rig = booted()
    # t is held until the tick: the 64-byte receive buffer fills, bytes are lost.
    sent = b"t\r\n" + b"v" * 70 + b"\r\n" + b"x\r\n"
    rig.rx(sent)
    assert rig.lost and len(rig.ring) == 64
    assert rig.dropped == list(range(2 + 64, len(sent)))   # all after the 64 that fit
    assert tx(ticks(rig)) == [OK]                # the LF of t's CRLF is swallowed
    assert rig.core.line_length == 40             # the v line (63 bytes), cut by the loss
    # the next byte in carries the loss: the v line runs on through the gap to x's CR
    assert say(rig, "x") == [b"E12 input overrun\r\n"]
    assert say(rig, "x") == [OK]                  # the decoder starts afresh


def test_overrun_of_an_empty_line_and_crlf():
    rig = booted()
    rig.rx(b"t\r")
    rig.rx(b"v" * 64 + b"\r")                     # 64 bytes fill the buffer; CR is lost
    assert tx(ticks(rig)) == [OK]                 # v*64 is fed; no loss seen yet
    assert say(rig, b"", b"\n") == [b"E12 input overrun\r\n"]   # the LF after the gap
    rig.core.rx_overrun()
    assert say(rig, b"", b"\n") == [b"E12 input overrun\r\n"]   # even when empty
    rig.rx(b"x\r")
    rig.core.rx_overrun()         # lost between CR and LF: the LF is not x's CRLF any more
    assert say(rig, b"", b"\n") == [b"E12 input overrun\r\n"]
    assert say(rig, "x") == [OK]


def test_bytes_fed_while_not_ready_count_as_lost():
    rig = booted()
    say(rig, "t")                                 # held; its LF waits in the ring
    rig.core.rx_byte(ord("x"))                    # a misbehaving caller: x is lost there
    assert tx(ticks(rig)) == [OK, b"E12 input overrun\r\n"]   # the LF ends the damage
    assert say(rig, "v", b"\r")[0].startswith(b"OK esair-min/1")


def test_decoder_buffer_never_grows():
    rig = booted()
    rig.rx(b"v" * 1000)
    assert rig.core.line_length == 40
    assert say(rig, b"") == [b"E02 line too long\r\n"]
    assert rig.core.line_length == 0


# -- the player ---------------------------------------------------------------------

def frames_of(number: int) -> list[bytes]:
    image = build_image(PAPAMAN)
    slot = next(s for s in PAPAMAN.layout.slots if s.number == number)
    return [image[slot.offset + k * 24: slot.offset + (k + 1) * 24] for k in range(slot.frames)]


def test_dance_writes_one_frame_per_tick():
    rig = booted()
    assert say(rig, "DNC") == [OK]
    lines = ticks(rig, 40)
    frames = frames_of(3)
    assert writes(lines) == [f"W 10 00{f.hex().upper()} ACK" for f in frames]
    per_tick = [line for line in lines if line.startswith(("T ", "W 10"))]
    assert per_tick[:4] == ["T 1", writes(lines)[0], "T 2", writes(lines)[1]]
    assert rig.core.playing is None
    assert rig.core.targets == PAPAMAN.motion("dance").frames[-1].angles
    assert tx(lines) == []


def test_sit_waits_its_delay():
    rig = booted()
    say(rig, "SIT")
    lines = ticks(rig, 60)
    at_ticks = []
    current = 0
    for line in lines:
        if line.startswith("T "):
            current = int(line[2:])
        elif line.startswith("W 10"):
            at_ticks.append(current)
    assert at_ticks == [1, 21, 41]
    assert rig.core.targets == (90, 90, 135, 135, 54, 90, 90, 90, 135, 135, 54, 90)


def test_stop_mid_motion():
    rig = booted()
    say(rig, "DNC")
    rig.tick(5)
    at = mark(rig)
    assert say(rig, "x") == [OK]
    assert writes(ticks(rig, 10)) == []
    assert [line for line in since(rig, at) if line.startswith("R 50")] == []
    assert say(rig, "t") == []                    # no longer busy


def test_poked_frame_outside_limits_stops_with_e04_and_is_not_written():
    rig = booted()
    slot = next(s for s in PAPAMAN.layout.slots if s.number == 3)
    rig.eeprom.poke(slot.offset + 2 * 24, 0x1E)    # frame 2, servo a: 30 degrees (< 60)
    say(rig, "DNC")
    lines = ticks(rig, 10)
    assert len(writes(lines)) == 2
    assert tx(lines) == [b"!E04 outside limits\r\n"]
    assert rig.core.playing is None


def test_poked_low_byte_of_100_is_refused():
    rig = booted()
    slot = next(s for s in PAPAMAN.layout.slots if s.number == 0)
    rig.eeprom.poke(slot.offset, 100)              # low 100 high 0: "angle 100" via low
    assert say(rig, "PLY00") == [OK]
    lines = ticks(rig)
    assert writes(lines) == [] and tx(lines) == [b"!E04 outside limits\r\n"]


def test_eeprom_and_actuator_failures_mid_motion():
    rig = booted()
    say(rig, "DNC")
    rig.tick()
    rig.eeprom.fault = True
    lines = ticks(rig)
    assert tx(lines) == [b"!E10 no answer on i2c\r\n"]      # written, next read failed
    assert len(writes(lines)) == 1 and rig.core.playing is None
    rig.eeprom.fault = False
    say(rig, "DNC")
    rig.actuator.fault = True
    lines = ticks(rig)
    assert tx(lines) == [b"!E10 no answer on i2c\r\n"]
    assert writes(lines)[0].endswith(" NACK") and rig.core.playing is None


def test_tick_order_held_write_then_player_then_reaction():
    rig = booted()
    rig.tick(4)
    say(rig, "oaa090")
    lines = ticks(rig)                             # tick 5: write, reply, poll
    assert [line.split()[0] for line in lines] == ["T", "W", "TX", "R"]


# -- the reaction -------------------------------------------------------------------

TIPPING = [300, 300, 300, 300, 100, 100, 100, 100]    # 1200 vs 400: 800 > 400
LEVEL = [200, 200, 200, 200, 150, 150, 150, 150]      # 800 vs 600: 200


def test_reaction_fires_after_three_tipping_polls():
    rig = booted()
    rig.sensor.set_readings(TIPPING)
    lines = ticks(rig, 14)
    assert len([line for line in lines if line.startswith("R 20")]) == 2
    assert tx(lines) == []
    lines = ticks(rig)                                 # tick 15: third tipping poll
    assert tx(lines) == [b"!R auto_balance\r\n"]
    assert rig.core.playing == 4
    assert lines[-1].startswith("R 50 03E6 24 ")       # balance's first frame
    lines = ticks(rig, 4)                              # polls skipped while it plays
    assert [line for line in lines if line.startswith("R 20")] == []
    lines = ticks(rig)                                 # tick 20: last frame, then a poll
    assert [line.split()[0] for line in lines] == ["T", "W", "R"]
    assert rig.core.playing is None


def test_reaction_count_restarts_on_a_level_sample():
    rig = booted()
    rig.sensor.set_readings(TIPPING)
    rig.tick(10)
    rig.sensor.set_readings(LEVEL)
    rig.tick(5)
    rig.sensor.set_readings(TIPPING)
    lines = ticks(rig, 14)                             # polls at 20, 25: only two
    assert tx(lines) == []
    assert tx(ticks(rig)) == [b"!R auto_balance\r\n"]  # tick 30


def test_reaction_preempts_a_dance():
    rig = booted()
    rig.sensor.set_readings(TIPPING)
    rig.tick(12)
    assert say(rig, "DNC") == [OK]
    lines = ticks(rig, 3)
    assert tx(lines) == [b"!R auto_balance\r\n"]
    assert rig.core.playing == 4
    balance = frames_of(4)
    lines = ticks(rig)
    assert writes(lines) == [f"W 10 00{balance[0].hex().upper()} ACK"]


def test_reaction_sensor_failure_notice_once():
    rig = booted()
    rig.sensor.fault = True
    lines = ticks(rig, 20)
    assert tx(lines) == [b"!E10 no answer on i2c\r\n"]
    assert len([line for line in lines if line.endswith(" NACK")]) == 4
    rig.sensor.fault = False
    rig.tick(5)
    rig.sensor.fault = True
    assert tx(ticks(rig, 5)) == [b"!E10 no answer on i2c\r\n"]


def test_reaction_does_not_fire_with_a_bad_image():
    rig = Rig(PAPAMAN)
    rig.eeprom.poke(9, 7)                              # sit's frame count
    rig.boot()
    rig.sensor.set_readings(TIPPING)
    assert tx(ticks(rig, 40)) == []


def test_reaction_with_a_silent_eeprom_notices_e10():
    rig = booted()
    rig.sensor.set_readings(TIPPING)
    rig.eeprom.fault = True
    assert tx(ticks(rig, 15)) == [b"!R auto_balance\r\n", b"!E10 no answer on i2c\r\n"]
    assert rig.core.playing is None


# -- devices, trace, harness --------------------------------------------------------

def test_devices():
    e = Eeprom24(16, 0x50, 2, b"\x01\x02")
    assert e.write_read(b"\x00\x0f", 3) == b"\xff\x01\x02"        # wraps at its size
    assert e.write(b"\x00\x05\xaa\xbb") and e.memory[5:7] == b"\xaa\xbb"
    e.fault = True
    assert e.write_read(b"\x00\x00", 1) is None and not e.write(b"\x00\x00")
    r = RegisterSlave(0x20, 4)
    r.set_readings([1023, 5])
    assert r.write_read(b"\x00", 4) == b"\xff\x03\x05\x00"
    assert r.write(b"\x03\x07\x08") and r.registers == bytearray(b"\x08\x03\x05\x07")
    assert r.pairs() == ((8, 3), (5, 7))
    bus = SimpleBus([e, r])
    assert bus.write_read(0x33, b"\x00", 1) is None and not bus.write(0x33, b"")
    assert NullBus().write_read(1, b"", 2) == b"\x00\x00"


@pytest.mark.parametrize("call, message", [
    (lambda: Eeprom24(4, 0x50, 2, b"12345"), "5 bytes do not fit a 4-byte EEPROM"),
    (lambda: Eeprom24(4, 0x50).load(b"12345"), "5 bytes do not fit a 4-byte EEPROM"),
    (lambda: Eeprom24(4, 0x50).poke(4, 0), "poke 0x4 0x0 is outside the 4-byte EEPROM or a byte"),
    (lambda: RegisterSlave(0x20, 2).set_readings([1, 2]), "2 readings for 1 sensors"),
    (lambda: RegisterSlave(0x20, 2).set_readings([1024]), "reading 1024 is not a 10-bit value"),
])
def test_device_errors(call, message):
    with pytest.raises(ProtocolError) as e:
        call()
    assert str(e.value) == message


def test_trace_writer_buffers_uart_lines():
    w = TraceWriter()
    w.tx(b"O")
    w.tx(b"K\r")
    w.tick(1)
    w.tx(b"\n!R")
    w.mark(125)
    w.close()
    assert w.lines == ["# esair-trace 1", "T 1", "TX 4F4B0D0A", "@ 125", "TX 2152"]
    assert without_marks(w.text()) == ["# esair-trace 1", "T 1", "TX 4F4B0D0A", "TX 2152"]
    bus = TracingBus(SimpleBus([RegisterSlave(0x10, 2)]), w)
    bus.write(0x10, b"\x00\xab")
    bus.write_read(0x11, b"\x00", 2)
    bus.write_read(0x10, b"\x01", 1)
    assert w.lines[-3:] == ["W 10 00AB ACK", "R 11 00 2 NACK", "R 10 01 1 00"]


def test_core_over_a_null_bus_stays_quiet():
    sent: list[bytes] = []
    core = CentralCore(PAPAMAN, NullBus(), sent.append)
    core.boot()
    assert sent == [b"!READY esair-min/1 image=bad\r\n"]


def test_harness_script(tmp_path):
    hexfile = tmp_path / "img.hex"
    write_hex(build_image(PAPAMAN), hexfile)
    script = ("# a comment\n\nimage img.hex\nboot\nrx v\\r\\n\n  tick 2  # trailing\n"
              "sensor 1 2 3 4 5 6 7 8\nrx s\\x0D\\n\nfault actuator on\nrx t\\r\\n\ntick\n"
              "fault actuator off\npoke 0 FF\nboot\n")
    lines = run_script(PAPAMAN, script, str(tmp_path / "s.txt"))
    assert tx(lines) == [
        ready(PAPAMAN), version(PAPAMAN),
        b"OK 1,2,3,4,5,6,7,8\r\n", b"E10 no answer on i2c\r\n",
        ready(PAPAMAN, False)]
    assert "T 3" in lines and "T 1" in lines


def test_harness_rx_is_verbatim():
    assert unescape("a #b\\\\\\x2a") == b"a #b\\*"
    lines = run_script(PAPAMAN, "boot\nrx x #\\r\n")
    assert tx(lines)[-1] == b"E03 bad argument\r\n"      # "x #" is 3 chars


# Bad scripts: tests/min/test_script.py (the same error on the Python and the C side).


def test_harness_main(tmp_path, capsys):
    script = tmp_path / "s.txt"
    script.write_text("boot\nrx x\\r\n")
    assert harness_main([str(ROOT / "boards" / "papaman"), str(script)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == "# esair-trace 1" and out[-1] == "TX 4F4B0D0A"
    assert harness_main([str(ROOT / "boards" / "papaman"), str(tmp_path / "none.txt")]) == 1
    assert capsys.readouterr().err == (f"error: cannot read {tmp_path / 'none.txt'}: "
                                       "No such file or directory\n")
    assert harness_main([]) == 2


def test_harness_main_with_a_bad_robot(tmp_path, capsys):
    script = tmp_path / "s.txt"
    script.write_text("boot\n")
    assert harness_main([str(tmp_path / "nothing"), str(script)]) == 1
    assert capsys.readouterr().err.startswith("error: ")
