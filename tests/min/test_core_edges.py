"""Corners of the Python core that a mutation run (scripts/mutation.sh) found untested:
boards without some device, a second reaction, the image's field ranges and Intel HEX
offsets, reply parsing, the byte-run feed. Expectations are absolute."""

from __future__ import annotations

import dataclasses
import struct

import pytest

from tests.support.boundary_cases import N, PAPAMAN, READY, STAND, Case, events, burst
from esair_min.core.central import CentralCore
from esair_min.core.decoder import CommandTable, Decoded
from esair_min.core.devices import Eeprom24, RegisterSlave, SimpleBus
from esair_min.core.stimulus import Rig, run_script
from esair_min.core.image import (build_image, crc16_ccitt, header_of, image_summary,
                                  parse_image, read_hex, write_hex)
from esair_min.core.player import BalanceReaction
from esair_min.core.protocol import Code, decode_pair, parse_reply
from esair_min.errors import ImageError, ProtocolError
from esair_min.model.board import Frame
from esair_min.model.robot import Robot

OK = b"OK\r\n"


def variant(robot: Robot, role: str, **updates) -> Robot:
    boards = tuple(b.model_copy(update=updates) if b.role == role else b
                   for b in robot.boards)
    return dataclasses.replace(robot, boards=boards)


def with_motions(robot: Robot, motions) -> Robot:
    return variant(robot, "central", motions=tuple(motions))


def with_eeprom(robot: Robot, **updates) -> Robot:
    devices = tuple(d.model_copy(update=updates) if d.kind == "eeprom" else d
                    for d in robot.central.i2c.devices)
    return variant(robot, "central",
                   i2c=robot.central.i2c.model_copy(update={"devices": devices}))


# -- boards without some device --------------------------------------------------------

def lone_central() -> Robot:
    """A central board with no I2C device at all: no motions, no reactions."""
    central = PAPAMAN.central
    commands = tuple(c for c in PAPAMAN.commands if c.action in ("version", "stop", "stand",
                                                                  "sensors"))
    board = central.model_copy(update={
        "i2c": central.i2c.model_copy(update={"devices": ()}), "motions": (),
        "reactions": (), "commands": commands})
    return dataclasses.replace(PAPAMAN, boards=(board,), files=PAPAMAN.files[1:2])


def test_a_central_board_without_devices():
    """No EEPROM: the image is ok without a read; no actuator or sensor board: the
    commands that need them are E10; nothing is ever put on the bus."""
    script = "boot\nrx v\\r\nrx t\\r\ntick\nrx s\\r\nrx x\\r\ntick 10\n"
    trace = run_script(lone_central(), script)
    assert [line for line in trace if line[0] in "RW"] == []
    assert events(trace) == [READY, "OK esair-min/1 servos=0 sensors=0 motions=0 image=ok "
                             "checksum=off", "E10 no answer on i2c", "E10 no answer on i2c",
                             "OK"]


def test_a_one_byte_address_eeprom():
    """A 24C02-class EEPROM takes one memory address byte: the image check and the
    frame reads send one."""
    robot = with_eeprom(PAPAMAN, address_bytes=1, size_bytes=256)
    robot = variant(robot, "central", motions=(PAPAMAN.motion("stand"),), reactions=(),
                    commands=tuple(c for c in PAPAMAN.commands if c.motion is None))
    trace = run_script(robot, "boot\nrx PLY00\\r\ntick\n")
    entry = "R 50 08 6 " + build_image(robot)[8:14].hex().upper()
    assert [line for line in trace if line.startswith("R 50")] == [
        "R 50 00 8 " + build_image(robot)[:8].hex().upper(),
        "R 50 08 30 " + build_image(robot)[8:].hex().upper(),
        entry,                                    # the directory's shape, at boot
        entry,                                    # PLY00 finds its entry
        "R 50 0E 24 " + build_image(robot)[14:].hex().upper()]
    assert events(trace) == [READY, "OK", burst(STAND)]


def test_boot_checks_the_crc_of_an_image_whose_first_motion_is_not_0():
    motions = [m.model_copy(update={"number": m.number + 1}) for m in PAPAMAN.motions]
    trace = run_script(with_motions(PAPAMAN, motions), "boot\nrx PLY01\\r\n")
    assert events(trace) == [READY, "OK"]


class FailingAfter:
    """A bus whose EEPROM stops answering after ``n`` reads."""

    def __init__(self, bus, n: int):
        self.bus, self.n, self.reads = bus, n, []

    def write(self, addr, data):
        return self.bus.write(addr, data)

    def write_read(self, addr, wdata, n):
        self.reads.append(wdata)
        if len(self.reads) > self.n:
            return None
        return self.bus.write_read(addr, wdata, n)


def test_a_body_read_that_fails_makes_the_image_bad_and_ends_the_check():
    eep = Eeprom24(32768, 0x50, 2, build_image(PAPAMAN))
    bus = FailingAfter(SimpleBus([eep]), 3)
    sent = []
    core = CentralCore(PAPAMAN, bus, sent.append)
    core.boot()
    assert sent == [b"!READY esair-min/1 image=bad\r\n"] and not core.image_ok
    assert bus.reads == [b"\x00\x00", b"\x00\x08", b"\x00\x28", b"\x00\x48"]


def test_a_new_core_before_boot():
    sent = []
    core = CentralCore(PAPAMAN, SimpleBus([]), sent.append)
    assert (core.ready(), core.ticks, core.image_ok, core.last_sensors, core.playing) == \
        (True, 0, False, None, None)
    assert core.targets == tuple(STAND) and sent == []


def test_boot_forgets_the_last_sensor_readings():
    rig = Rig(PAPAMAN)
    rig.boot()
    rig.rx(b"s\r")
    assert rig.core.last_sensors == (0,) * 8
    rig.boot()
    assert rig.core.last_sensors is None


def test_rx_run_is_rx_byte_of_each_byte():
    """The emulator's byte-run feed gives what feeding byte by byte gives, also while a
    held write makes the decoder lose bytes."""
    data = b"v\r\nt\r\nx\r\nx\r\n" + b"PLY03\r" + b"oab100\r\n"
    out = []
    for feed in ("bytes", "run"):
        sent: list[bytes] = []
        eep = Eeprom24(32768, 0x50, 2, build_image(PAPAMAN))
        core = CentralCore(PAPAMAN, SimpleBus([eep, RegisterSlave(0x10, 24),
                                               RegisterSlave(0x20, 16)]), sent.append)
        core.boot()
        for chunk in (data, b"x\r"):
            if feed == "bytes":
                for b in chunk:
                    core.rx_byte(b)
            else:
                core.rx_run(chunk)
            core.tick()
        out.append(sent)
    assert out[0] == out[1]
    assert out[0][:3] == [b"!READY esair-min/1 image=ok crc=2C20\r\n",
                          b"OK esair-min/1 servos=12 sensors=8 motions=5 image=ok crc=2C20 "
                          b"checksum=off\r\n", OK]
    assert b"E12 input overrun\r\n" in out[0]


# -- two reactions ---------------------------------------------------------------------

def two_reactions(poll_a: int, poll_b: int) -> Robot:
    first = PAPAMAN.central.reactions[0]
    second = first.model_copy(update={"name": "second", "poll_ticks": poll_b,
                                      "motion": "stand"})
    return variant(PAPAMAN, "central",
                   reactions=(first.model_copy(update={"poll_ticks": poll_a}), second))


def polls(trace: list[str]) -> list[int]:
    """The tick of every sensor read."""
    out, tick = [], 0
    for line in trace:
        if line.startswith("T "):
            tick = int(line[2:])
        elif line.startswith("R 20 "):
            out.append(tick)
    return out


def test_each_reaction_polls_on_its_own_period():
    trace = run_script(two_reactions(5, 3), "boot\ntick 10\n")
    assert polls(trace) == [3, 5, 6, 9, 10]


def test_a_failed_poll_does_not_skip_the_next_reaction():
    trace = run_script(two_reactions(5, 5), "boot\nfault sensor on\ntick 5\n")
    assert polls(trace) == [5, 5]
    assert events(trace) == [READY, "!E10 no answer on i2c", "!E10 no answer on i2c"]


def test_polls_are_skipped_while_the_reaction_motion_plays():
    """balance (3 frames, delay 2) started at tick 1 plays through tick 5's poll."""
    script = "boot\ntick\nrx PLY04\\r\ntick 9\n"
    assert polls(run_script(PAPAMAN, script)) == [10]
    assert polls(run_script(PAPAMAN, script.replace("PLY04", "PLY00"))) == [5, 10]


# -- the reaction alone ------------------------------------------------------------------

def test_the_count_restarts_after_firing_and_after_a_failed_poll():
    assert BalanceReaction("r", [0], [1], 10, 3, 1, 4).failed() is True   # notice due
    r = BalanceReaction("r", [0], [1], threshold=10, samples=3, poll_ticks=1, motion=4)
    tip = [100, 0]
    assert [r.sample(tip) for _ in range(6)] == [False, False, True, False, False, True]
    assert r.failed() is True and r.failed() is False
    assert [r.sample(tip) for _ in range(3)] == [False, False, True]
    r.sample(tip)
    r.failed()
    assert [r.sample(tip) for _ in range(3)] == [False, False, True]


# -- the command table -------------------------------------------------------------------

def test_the_command_table_for_clients():
    numbers = {m.name: m.number for m in PAPAMAN.motions}
    table = CommandTable(PAPAMAN.commands, N, numbers)       # no checksum required
    d = table.decode(b"oab100")
    assert isinstance(d, Decoded) and d.row.command.name == "motor"
    assert (d.action, d.args) == ("motor", (0, 1, 100))
    assert table.decode(b"oma090") == Code.BAD_ARGUMENT
    assert table.decode(b"a" + b"001" * 11 + b"00/") == Code.BAD_ARGUMENT
    assert table.decode(b"PLY1:") == Code.BAD_ARGUMENT
    assert table.decode(b"SIT").args == (1,)


# -- protocol helpers --------------------------------------------------------------------

def test_decode_pair_ranges():
    assert decode_pair(99, 255) == (599, 25)
    for low, high in ((100, 0), (0, 256), (-1, 0), (0, -1)):
        with pytest.raises(ProtocolError) as e:
            decode_pair(low, high)
        assert str(e.value) == f"pair ({low}, {high}) is not a servo encoding"


def test_parse_reply_keeps_the_text_and_strips_only_the_terminator():
    assert parse_reply(b"OK 1,2,MAX \r\n").data == "1,2,MAX "
    assert parse_reply(b"!X\r\n").data == "X"
    e = parse_reply("E04 outside limits\r\n")
    assert (e.kind, e.code, e.data) == ("error", Code.OUTSIDE_LIMITS, "E04 outside limits")
    with pytest.raises(ProtocolError) as err:
        parse_reply(b"\xffOK\r\n")
    assert str(err.value) == "not a reply line: '\ufffdOK'"


# -- the EEPROM image --------------------------------------------------------------------

def test_per_servo_speeds_round_trip():
    frame = Frame(angles=tuple(STAND), speed=tuple(range(N)))
    image = build_image(with_motions(PAPAMAN, [m.model_copy(update={"frames": (frame,)})
                                               if m.number == 0 else m
                                               for m in PAPAMAN.motions]))
    parsed = parse_image(image, PAPAMAN)
    assert parsed.motion(0).poses()[0] == tuple((90, s) for s in range(N))
    assert [m.offset for m in parsed.motions] == [s.offset for s in PAPAMAN.layout.slots]


def test_directory_fields_use_their_whole_unsigned_range():
    """A delay of 200 ticks and an offset past 32767 are stored and read back as such."""
    dance = PAPAMAN.motion("dance")
    motions = [m.model_copy(update={"delay_ticks": 200}) if m.number == 0 else m
               for m in PAPAMAN.motions]
    motions += [dance.model_copy(update={"name": f"m{i}", "number": 10 + i,
                                         "frames": dance.frames * 4}) for i in range(12)]
    robot = with_eeprom(with_motions(PAPAMAN, motions), size_bytes=65536)
    parsed = parse_image(build_image(robot), robot)
    assert parsed.motion(0).delay_ticks == 200
    assert parsed.motions[-1].offset == robot.layout.slots[-1].offset > 32767
    assert len(parsed.motions[-1].frames) == 128


def test_image_filling_the_eeprom_exactly():
    assert len(build_image(with_eeprom(PAPAMAN, size_bytes=1070))) == 1070
    with pytest.raises(ImageError) as e:
        build_image(with_eeprom(PAPAMAN, size_bytes=1069))
    assert str(e.value) == "the motion image needs 1070 bytes but EEPROM 'motion_store' has 1069"


def test_an_image_of_65536_bytes_is_refused():
    """8 + 6*13 + 22*2975 = 65536 (11 servos, 13 motions): one byte over 16 bits."""
    servos = PAPAMAN.actuator.servos[:11]
    robot = variant(PAPAMAN, "actuator", servos=servos)
    frame = Frame(angles=(90,) * 11, speed=2)
    frames = [229] * 12 + [227]
    motions = [PAPAMAN.motion("dance").model_copy(
        update={"name": f"m{i}", "number": i, "frames": (frame,) * n})
        for i, n in enumerate(frames)]
    robot = variant(with_eeprom(robot, size_bytes=131072), "central",
                    motions=tuple(motions), reactions=())
    with pytest.raises(ImageError) as e:
        build_image(robot)
    assert str(e.value) == "the motion image needs 65536 bytes, more than 65535"


def image_with(entries: list[tuple[int, int, int, int, int]], body: bytes = b"") -> bytes:
    directory = b"".join(struct.pack("<BBBBH", *e) for e in entries)
    rest = directory + body
    return struct.pack("<2sBBHH", b"EM", 2, len(entries), 8 + len(rest),
                       crc16_ccitt(rest)) + rest


def test_header_needs_exactly_eight_bytes():
    assert header_of(image_with([])).length == 8
    with pytest.raises(ImageError) as e:
        header_of(image_with([])[:7])
    assert str(e.value) == "image is 7 bytes, shorter than its 8-byte header"


def test_an_image_without_motions():
    parsed = parse_image(image_with([]))
    assert (parsed.motions, parsed.frame_bytes, parsed.frame_count) == ((), 0, 0)
    with pytest.raises(ImageError) as e:
        parse_image(image_with([], b"\x00\x00"))
    assert str(e.value) == "2 frame bytes do not hold 0 frames"


@pytest.mark.parametrize("entries, body, message", [
    ([(0, 1, 1, 1, 14)], b"", "0 frame bytes do not hold 1 frames"),
    ([(0, 1, 1, 1, 14)], b"\x00\x00\x00", "3 frame bytes do not hold 1 frames"),
    ([(100, 1, 1, 1, 14)], b"\x00\x00", "directory: motion number 100 out of order or above 99"),
    ([(0, 1, 1, 0, 14)], b"\x00\x00", "directory: motion 0 has frames 1, delay 1, servos 0"),
])
def test_parse_refuses(entries, body, message):
    with pytest.raises(ImageError) as e:
        parse_image(image_with(entries, body))
    assert str(e.value) == message


def test_motion_number_99_and_a_servo_named_in_a_low_byte_error():
    assert parse_image(image_with([(99, 1, 1, 1, 14)], b"\x00\x00")).motion(99).frames == \
        (b"\x00\x00",)
    with pytest.raises(ImageError) as e:
        parse_image(image_with([(0, 1, 1, 6, 14)], b"\x00\x00" * 5 + b"\x64\x00"))
    assert str(e.value) == "motion 0 frame 0: servo 5 low byte 100 is not below 100"


def test_hex_addresses(tmp_path):
    """Bytes land at their own addresses (blank before); data at the EEPROM's size
    is beyond it."""
    from intelhex import IntelHex
    ih = IntelHex()
    ih[4] = 0x12
    ih[15] = 0x34
    path = tmp_path / "x.hex"
    ih.write_hex_file(str(path))
    assert read_hex(path, 16) == b"\xff" * 4 + b"\x12" + b"\xff" * 10 + b"\x34"
    with pytest.raises(ImageError) as e:
        read_hex(path, 15)
    assert str(e.value) == f"{path}: data at address 0xF, beyond the 15-byte EEPROM"
    write_hex(b"\x01\x02", path)
    assert read_hex(path, 4) == b"\x01\x02\xff\xff"
    cr = tmp_path / "cr.hex"              # lines ended by CR alone are lines too
    cr.write_bytes(path.read_bytes().replace(b"\r\n", b"\n").replace(b"\n", b"\r"))
    assert b"\n" not in cr.read_bytes()
    assert read_hex(cr, 4) == b"\x01\x02\xff\xff"


def test_summary_of_a_robot_without_an_eeprom():
    robot = lone_central()
    image = image_with([])
    assert image_summary(robot, image) == \
        "papaman: 0 motions, 0 frames, 8 of 8 bytes used, CRC 0xFFFF"


def test_stand_angle_100_encodes_its_hundreds():
    """angle 100: low 0, high 1 + 10*speed (the only angle below 202 where /100 and
    /101 differ)."""
    servos = tuple(s.model_copy(update={"stand_angle": 100}) if s.index == 2 else s
                   for s in PAPAMAN.actuator.servos)
    robot = variant(PAPAMAN, "actuator", servos=servos)
    case = Case("stand 100")
    case.rx("t")
    case.tick()
    angles = list(STAND)
    angles[2] = 100
    assert events(run_script(robot, case.text)) == [READY, burst(angles), "OK"]
