"""Hypothesis properties of the decoder and the core (issue 3, item 4)."""

from __future__ import annotations

import pytest

import dataclasses
from pathlib import Path

from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from esair_min.core.central import CentralCore
from esair_min.core.decoder import CommandTable, Decoded
from esair_min.core.devices import Eeprom24, RegisterSlave, SimpleBus
from esair_min.core.image import build_image
from esair_min.core.protocol import (MAX_LINE, add_checksum, decode_pair, encode_angles,
                                encode_motor, encode_pair, encode_play, encode_speeds,
                                parse_reply)
from esair_min.model.robot import Robot
from esair_min.model.validate import load_robot

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
PAPAMAN = load_robot(ROOT / "boards" / "papaman")
N = len(PAPAMAN.servos)
LIMITS = [(s.min_angle, s.max_angle) for s in PAPAMAN.servos]
NUMBERS = {m.name: m.number for m in PAPAMAN.motions}
PROPS = settings(max_examples=150, deadline=None,
                 suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def variant(robot: Robot, role: str, **updates) -> Robot:
    boards = tuple(b.model_copy(update=updates) if b.role == role else b
                   for b in robot.boards)
    return dataclasses.replace(robot, boards=boards)


CHECKSUMMED = variant(PAPAMAN, "central", uart=PAPAMAN.central.uart.model_copy(
    update={"require_checksum": True}))
# Servo a may go to 999 degrees and stands at 650: now E05 (overflow) is reachable from
# `o` and, after `a` sets a high speed, from `t`.
WIDE = variant(PAPAMAN, "actuator", servos=tuple(
    s.model_copy(update={"max_angle": 999, "min_angle": 0, "stand_angle": 650})
    if s.index == 0 else s for s in PAPAMAN.actuator.servos))
ROBOT = {"papaman": PAPAMAN, "wide": WIDE}
ROBOTS = sorted(ROBOT)


class CheckingBus(SimpleBus):
    """A bus that remembers every acknowledged actuator pair and refuses bad ones."""

    def __init__(self, robot: Robot, devices, actuator: int):
        super().__init__(devices)
        self.limits = [(s.min_angle, s.max_angle) for s in robot.servos]
        self.actuator = actuator
        self.written: dict[int, int] = {}          # servo -> angle last written

    def write(self, addr: int, data: bytes) -> bool:
        if addr == self.actuator and data:       # an empty write is `i`'s address probe
            reg, pairs = data[0], data[1:]
            assert reg % 2 == 0 and len(pairs) % 2 == 0
            assert reg // 2 + len(pairs) // 2 <= len(self.limits)
            decoded = {}
            for k in range(0, len(pairs), 2):
                servo = reg // 2 + k // 2
                low, high = pairs[k], pairs[k + 1]
                assert low < 100, (servo, low, high)
                angle = (high % 10) * 100 + low
                lo, hi = self.limits[servo]
                assert lo <= angle <= hi, (servo, angle)
                decoded[servo] = angle
            ack = super().write(addr, data)
            if ack:
                self.written.update(decoded)
            return ack
        return super().write(addr, data)


class Board:
    """A core over simple devices, driven as the firmware's superloop would."""

    def __init__(self, robot: Robot = PAPAMAN, boot: bool = True):
        self.robot = robot
        eep, act, sen = robot.eeprom, robot.peer("actuator"), robot.peer("sensor")
        self.eeprom = Eeprom24(eep.size_bytes, eep.address, eep.address_bytes,
                               build_image(robot))
        self.actuator = RegisterSlave(act.address, act.registers)
        self.sensor = RegisterSlave(sen.address, sen.registers)
        self.bus = CheckingBus(robot, [self.eeprom, self.actuator, self.sensor], act.address)
        self.sent: list[bytes] = []
        self.core = CentralCore(robot, self.bus, self.sent.append)
        if boot:
            self.core.boot()

    def feed(self, data: bytes) -> None:
        core = self.core
        for b in data:
            while not core.ready():
                core.tick()
            core.rx_byte(b)
            assert core.line_length <= MAX_LINE
        while not core.ready():
            core.tick()

    def replies(self, start: int = 0) -> list[bytes]:
        """Lines that answer commands (notices skipped)."""
        return [line for line in self.sent[start:] if not line.startswith(b"!")]

    def check_targets(self) -> None:
        """Every servo written so far holds the core's current target."""
        for servo, angle in self.bus.written.items():
            assert self.core.targets[servo] == angle


# -- strategies ---------------------------------------------------------------------

def angle_in(i: int) -> st.SearchStrategy[int]:
    lo, hi = LIMITS[i]
    return st.integers(lo, hi)


def code_angle(i: int) -> st.SearchStrategy[int | None]:
    lo, hi = LIMITS[i]
    return st.none() | st.integers(-(-lo // 3), hi // 3).map(lambda k: 3 * k)


#: (action, args, line): syntactically valid commands of every kind.
any_command = st.one_of(
    st.just(("stand", (), "t")),
    st.just(("version", (), "v")),
    st.just(("sensors", (), "s")),
    st.just(("stop", (), "x")),
    st.sampled_from([("play", (NUMBERS["sit"],), "SIT"), ("play", (NUMBERS["dance"],), "DNC")]),
    st.tuples(st.integers(0, N - 1), st.integers(0, 25), st.integers(0, 999)).map(
        lambda a: ("motor", a, encode_motor(*a))),
    st.integers(0, 99).map(lambda n: ("play", (n,), encode_play(n))),
    st.lists(st.integers(0, 25), min_size=N, max_size=N).map(
        lambda s: ("speeds", tuple(s), encode_speeds(s))),
    st.lists(st.none() | st.sampled_from([0, 180]) | st.integers(0, 60).map(lambda k: 3 * k),
             min_size=N, max_size=N).map(
        lambda a: ("angles", tuple(a), encode_angles(a))),
)

#: Commands that succeed on an idle PAPA-MAN (arguments inside the limits).
good_command = st.one_of(
    st.sampled_from(["t", "v", "s", "x", "SIT", "DNC", "PLY00", "PLY04"]),
    st.integers(0, N - 1).flatmap(lambda m: st.tuples(st.just(m), st.integers(0, 25),
                                                      angle_in(m))).map(
        lambda a: encode_motor(*a)),
    st.lists(st.integers(0, 25), min_size=N, max_size=N).map(encode_speeds),
    st.tuples(*[code_angle(i) for i in range(N)]).map(encode_angles),
)

line_text = st.one_of(
    any_command.map(lambda c: c[2]),
    good_command,
    st.text(alphabet=st.characters(min_codepoint=0x20, max_codepoint=0x7E), max_size=45),
)
maybe_checksummed = st.tuples(line_text, st.booleans()).map(
    lambda t: add_checksum(t[0]) if t[1] else t[0])
terminator = st.sampled_from([b"\r", b"\n", b"\r\n"])
#: Byte soup: command lines, garbage bytes and terminators mixed.
soup = st.lists(st.one_of(maybe_checksummed.map(str.encode), st.binary(max_size=50),
                          terminator), max_size=25).map(b"".join)


# -- properties ---------------------------------------------------------------------

@PROPS
@given(st.binary(max_size=600) | soup)
def test_arbitrary_bytes_never_raise_nor_grow_the_buffer(data):
    board = Board()
    board.feed(data)                    # asserts the line length after every byte
    for line in board.sent:
        assert line.endswith(b"\r\n")
        parse_reply(line)               # every line sent is a reply or a notice


@PROPS
@given(st.lists(st.tuples(st.one_of(maybe_checksummed.map(str.encode),
                                    st.binary(max_size=60).map(
                                        lambda b: b.replace(b"\r", b"").replace(b"\n", b""))),
                          terminator), max_size=20))
def test_every_terminated_line_is_answered_once(lines):
    board = Board()
    start = len(board.sent)
    board.feed(b"".join(text + end for text, end in lines))
    assert len(board.replies(start)) == sum(1 for text, _ in lines if text)


@PROPS
@given(st.binary(max_size=200) | soup, terminator, good_command, st.booleans())
def test_after_any_garbage_the_next_valid_command_works(garbage, end, command, checksum):
    board = Board()
    board.feed(garbage + end)
    start = len(board.sent)
    board.feed(b"x\r\n")
    assert board.replies(start) == [b"OK\r\n"]
    start = len(board.sent)
    line = add_checksum(command) if checksum else command
    board.feed(line.encode() + b"\r\n")
    replies = board.replies(start)
    assert len(replies) == 1 and replies[0].startswith(b"OK"), (line, replies)


@PROPS
@given(any_command, st.booleans())
def test_every_valid_command_round_trips(command, checksum):
    action, args, line = command
    table = CommandTable(PAPAMAN.commands, N, NUMBERS, require_checksum=checksum)
    decoded = table.decode((add_checksum(line) if checksum else line).encode())
    assert isinstance(decoded, Decoded)
    assert (decoded.action, decoded.args) == (action, args)


#: Commands that matter for the limits: plays, stops, stands, extreme speeds and motor
#: lines biased to servo a (wide on WIDE) at high speeds and angles.
extreme_motor = st.tuples(st.just(0) | st.integers(0, N - 1),
                          st.sampled_from([24, 25]) | st.integers(0, 25),
                          st.integers(550, 999) | st.integers(0, 999)).map(
    lambda a: encode_motor(*a))
risky_line = st.one_of(
    st.sampled_from(["PLY00", "PLY01", "PLY02", "DNC", "PLY04", "x", "t",
                     "a" + "025" * N, "a" + "024" * N, "a" + "000" * N]),
    extreme_motor,
    extreme_motor,
    any_command.map(lambda c: c[2]),
)
steps = st.lists(st.one_of(
    risky_line.map(lambda c: ("rx", c.encode() + b"\r")),
    soup.map(lambda d: ("rx", d)),
    st.integers(1, 40).map(lambda n: ("tick", n)),
    st.tuples(st.integers(38, 1069) | st.integers(0, 1100), st.integers(0, 255)).map(
        lambda p: ("poke", p)),
    st.lists(st.integers(0, 1023), min_size=8, max_size=8).map(lambda v: ("sensor", v)),
    st.tuples(st.sampled_from(["actuator", "sensor", "eeprom"]), st.booleans()).map(
        lambda f: ("fault", f)),
    st.just(("boot", None)),
), max_size=40)


def run_steps(board: Board, script) -> None:
    devices = {"actuator": board.actuator, "sensor": board.sensor, "eeprom": board.eeprom}
    for kind, arg in script:
        if kind == "rx":
            board.feed(arg)
        elif kind == "tick":
            for _ in range(arg):
                board.core.tick()
        elif kind == "poke":
            board.eeprom.poke(*arg)
        elif kind == "sensor":
            board.sensor.set_readings(arg)
        elif kind == "fault":
            devices[arg[0]].fault = arg[1]
        else:
            board.core.boot()
            board.bus.written.clear()       # reset: the core's targets restart too
        board.check_targets()               # (the CheckingBus asserts every pair)


@PROPS
@given(st.sampled_from(ROBOTS), steps)
@example("papaman", [("rx", b"i\r")])          # the bus scan probes each address empty
def test_actuator_writes_stay_inside_the_limits_for_any_mix(robot, script):
    run_steps(Board(ROBOT[robot]), script)


@PROPS
@given(st.sampled_from(ROBOTS),
       st.lists(st.tuples(risky_line, st.integers(0, 3) | st.integers(0, 40)), min_size=1,
                max_size=30))
def test_actuator_writes_stay_inside_the_limits_for_any_command(robot, lines):
    script = []
    for line, ticks in lines:
        script += [("rx", line.encode() + b"\r\n"), ("tick", ticks)]
    run_steps(Board(ROBOT[robot]), script)


@PROPS
@given(st.lists(st.tuples(st.integers(38, 1069), st.integers(0, 255)), min_size=1,
                max_size=8), st.booleans(), st.sampled_from(ROBOTS))
def test_actuator_writes_stay_inside_the_limits_for_any_eeprom_corruption(pokes, before,
                                                                         robot):
    board = Board(ROBOT[robot], boot=not before)
    original = bytes(board.eeprom.memory)
    for p in pokes:
        board.eeprom.poke(*p)
    script = [("boot", None)] if before else []
    for m in PAPAMAN.motions:
        script += [("rx", b"x\r" + encode_play(m.number).encode() + b"\r"), ("tick", 90)]
    run_steps(board, script)
    if before and board.eeprom.memory != original:
        # a corrupted image is refused at reset: nothing is ever written
        assert not board.core.image_ok and not board.bus.written


def test_pair_encoding_matches_the_formula_for_every_angle_and_speed():
    for angle in range(1000):
        for speed in range(26):
            high = angle // 100 + 10 * speed
            if high > 255:
                try:
                    encode_pair(angle, speed)
                except Exception as exc:        # noqa: BLE001 - the type is asserted
                    assert type(exc).__name__ == "ProtocolError"
                else:
                    raise AssertionError(f"{angle} {speed} did not overflow")
                continue
            assert encode_pair(angle, speed) == (angle % 100, high)
            assert decode_pair(angle % 100, high) == (angle, speed)


@PROPS
@given(st.integers(0, N - 1).flatmap(lambda m: st.tuples(st.just(m), st.integers(0, 25),
                                                         angle_in(m))),
       st.lists(st.integers(0, 25), min_size=N, max_size=N),
       st.tuples(*[code_angle(i) for i in range(N)]))
def test_the_core_writes_the_formula(motor, speeds, angles):
    board = Board()
    m, s, a = motor
    writes: list[bytes] = []
    board.bus.write = lambda addr, data: writes.append(data) or True   # type: ignore
    board.feed(encode_motor(m, s, a).encode() + b"\r\n")
    assert writes == [bytes((2 * m, a % 100, a // 100 + 10 * s))]
    board.feed(encode_speeds(speeds).encode() + b"\r\n" + encode_angles(angles).encode()
               + b"\r\n")
    targets = [a if i == m else s_.stand_angle for i, s_ in enumerate(PAPAMAN.servos)]
    expect = bytearray([0])
    for i, (angle, speed) in enumerate(zip(angles, speeds)):
        t = targets[i] if angle is None else angle
        expect += bytes((t % 100, t // 100 + 10 * speed))
    assert writes[1] == bytes(expect)


def _is_harmless(board: Board, start: int) -> bool:
    replies = board.replies(start)
    return (all(r[:1] == b"E" for r in replies) and not board.bus.written
            and board.core.playing is None and board.core.speeds == (2,) * N)


@PROPS
@given(any_command, st.data())
def test_checksum_catches_every_single_byte_corruption(command, data):
    line = add_checksum(command[2]).encode()
    i = data.draw(st.integers(0, len(line) - 1))
    value = data.draw(st.integers(0, 255).filter(lambda v: v != line[i]))
    board = Board(CHECKSUMMED)
    start = len(board.sent)
    board.feed(line[:i] + bytes([value]) + line[i + 1:] + b"\r\n")
    assert _is_harmless(board, start), (line, i, value, board.sent[start:])


def test_checksum_catches_every_corruption_of_sample_lines():
    """Exhaustive over positions and byte values for one line of each kind."""
    lines = ["t", "v", "s", "x", "SIT", "DNC", "PLY04", "oab100", encode_speeds([25] * N),
             encode_angles([None] * 3 + [120] * 9)]
    board = Board(CHECKSUMMED)
    for text in lines:
        line = add_checksum(text).encode()
        for i in range(len(line)):
            for value in range(256):
                if value == line[i]:
                    continue
                start = len(board.sent)
                board.feed(line[:i] + bytes([value]) + line[i + 1:] + b"\r\n")
                assert _is_harmless(board, start), (line, i, value, board.sent[start:])
    start = len(board.sent)
    board.feed(add_checksum("PLY04").encode() + b"\r\n")
    assert board.replies(start) == [b"OK\r\n"]       # the same board still works
