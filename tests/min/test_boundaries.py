"""Every boundary of the Python core pinned from both sides, with absolute expectations
(docs/mutation.md: the mutants these tests kill).

The stimulus cases of tests/support/boundary_cases.py (also run on the host-built C core by
tests/min/test_boundaries_c.py), then what only the Python core can be given: robots whose
stand angles, limits or checksum rule differ from PAPA-MAN's, the EEPROM image's
limits and the reaction's comparison on its own.
"""

from __future__ import annotations

import dataclasses

import pytest

from tests.support.boundary_cases import (E04, LIMITS, MAX_LINE, N, OK, PAPAMAN, READY, RX_RING, STAND,
                            Case, all_cases, burst, events, ring_case)
from esair_min.core.decoder import LineAssembler
from esair_min.core.stimulus import run_script
from esair_min.core.image import build_image, parse_image
from esair_min.core.player import BalanceReaction
from esair_min.core.protocol import Code, add_checksum
from esair_min.errors import ImageError
from esair_min.model.board import Frame
from esair_min.model.robot import Robot

CASES = all_cases()


def run(case: Case, robot: Robot = PAPAMAN) -> list[str]:
    return events(run_script(robot, case.text, "boundary.txt"), case.ticks)


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_boundary_case(case):
    assert run(case) == case.expected


def test_the_ring_holds_64_bytes():
    assert run(ring_case(0)) == [READY, burst(STAND), OK] + [OK] * (RX_RING // 2)


def test_the_65th_byte_is_lost_and_answered_e12():
    """The lost byte is marked on the next byte that gets in (the CR sent after the
    tick): every x line that arrived whole runs, the damaged one is E12."""
    assert run(ring_case(1)) == \
        [READY, burst(STAND), OK] + [OK] * (RX_RING // 2) + ["E12 input overrun"]


# -- robots other than PAPA-MAN -------------------------------------------------------

def variant(robot: Robot, role: str, **updates) -> Robot:
    boards = tuple(b.model_copy(update=updates) if b.role == role else b
                   for b in robot.boards)
    return dataclasses.replace(robot, boards=boards)


def with_servo(robot: Robot, index: int, **updates) -> Robot:
    servos = tuple(s.model_copy(update=updates) if s.index == index else s
                   for s in robot.actuator.servos)
    return variant(robot, "actuator", servos=servos)


def calm(robot: Robot) -> Robot:
    """Every stored frame at the stand angles (so narrowed limits still build)."""
    motions = tuple(m.model_copy(update={"frames": tuple(
        f.model_copy(update={"angles": tuple(STAND)}) for f in m.frames)})
        for m in robot.motions)
    return variant(robot, "central", motions=motions)


def stand(robot: Robot, *lines: str) -> list[str]:
    case = Case("stand")
    for line in lines:
        case.rx(line)
    case.tick()
    return run(case, robot)


@pytest.mark.parametrize("servo", range(N))
def test_stand_at_and_beyond_each_limit(servo):
    """``t`` (the all-servos path) with one servo's stand angle on a limit is written;
    one degree beyond, it is E04 and nothing is written."""
    lo, hi = LIMITS[servo]
    for angle in (lo, hi):
        angles = list(STAND)
        angles[servo] = angle
        robot = with_servo(PAPAMAN, servo, stand_angle=angle)
        assert stand(robot, "t") == [READY, burst(angles), OK]
    for angle in (lo - 1, hi + 1):
        robot = with_servo(PAPAMAN, servo, stand_angle=angle)
        assert stand(robot, "t") == [READY, E04]


@pytest.mark.parametrize("servo", range(N))
def test_angles_exactly_at_and_one_beyond_each_limit(servo):
    """``c`` with limits moved onto its 3-degree grid (at a limit: written) and one
    degree inside it (the same code is one degree beyond: E04)."""
    lo, hi = LIMITS[servo]
    lo3, hi3 = -(-lo // 3) * 3, hi // 3 * 3
    codes = {a: "." * servo + chr(0x30 + a // 3) + "." * (N - 1 - servo) for a in (lo3, hi3)}
    at = calm(with_servo(PAPAMAN, servo, min_angle=lo3, max_angle=hi3))
    inside = calm(with_servo(PAPAMAN, servo, min_angle=lo3 + 1, max_angle=hi3 - 1))
    for a, code in codes.items():
        angles = list(STAND)
        angles[servo] = a
        assert stand(at, "c" + code) == [READY, burst(angles), OK]
        assert stand(inside, "c" + code) == [READY, E04]


def test_overflow_at_255_in_the_all_servos_path():
    """high = angle/100 + 10*speed: 255 is written, 256 is E05 (``t`` and ``c``)."""
    fits = with_servo(PAPAMAN, 0, max_angle=999, stand_angle=500)
    speeds = "a" + "025" * N
    angles = [500] + STAND[1:]
    assert stand(fits, speeds, "t") == [READY, OK, burst(angles, [25] * N), OK]
    over = with_servo(PAPAMAN, 0, max_angle=999, stand_angle=600)
    assert stand(over, speeds, "t") == [READY, OK, "E05 speed/angle overflow"]
    assert stand(over, "t") == [READY, burst([600] + STAND[1:]), OK]      # speed 2: 26


def test_motor_overflow_at_255():
    robot = with_servo(PAPAMAN, 0, max_angle=999)
    case = Case("motor overflow")
    case.rx("oaz599")
    case.tick()
    case.rx("oaz600")
    assert run(case, robot) == [READY, "W 0063FF", OK, "E05 speed/angle overflow"]


def test_a_checksum_alone_is_a_checksummed_empty_line():
    """With checksums required, ``*00`` (3 characters: the shortest line with a suffix)
    is stripped and matches nothing (E01), it is not a line without a checksum (E11)."""
    uart = PAPAMAN.central.uart.model_copy(update={"require_checksum": True})
    case = Case("required")
    case.rx("*00", "E01 unknown command")
    case.rx("x*7", "E11 checksum required")
    case.rx(add_checksum("x"), OK)
    assert run(case, variant(PAPAMAN, "central", uart=uart)) == case.expected


# -- the line assembler alone -----------------------------------------------------------

def test_the_buffer_keeps_exactly_40_bytes():
    la = LineAssembler()
    for b in b"v" * MAX_LINE:
        assert la.feed(b) is None
    assert la.length == MAX_LINE and not la.overflow
    assert la.feed(0x0D) == b"v" * MAX_LINE
    for b in b"v" * MAX_LINE + b"\x01":
        la.feed(b)
    assert la.length == MAX_LINE and la.overflow
    assert la.feed(0x0D) == Code.TOO_LONG
    for b in b"v" * (MAX_LINE - 1) + b"\x01":
        la.feed(b)
    assert la.length == MAX_LINE and not la.overflow and la.bad
    assert la.feed(0x0A) == Code.BAD_CHARACTER


@pytest.mark.parametrize("b, printable", [(0x1F, False), (0x20, True), (0x7E, True),
                                          (0x7F, False), (0x00, False), (0xFF, False)])
def test_printable_range(b, printable):
    la = LineAssembler()
    la.feed(b)
    assert la.feed(0x0D) == (bytes([b]) if printable else Code.BAD_CHARACTER)


# -- the EEPROM image -------------------------------------------------------------------

def with_stand_frame(robot: Robot, angles: list[int]) -> Robot:
    motions = tuple(m.model_copy(update={"frames": (Frame(angles=tuple(angles), speed=2),)})
                    if m.name == "stand" else m for m in robot.motions)
    return variant(robot, "central", motions=motions)


@pytest.mark.parametrize("servo", range(N))
def test_image_frames_at_and_beyond_each_limit(servo):
    """A stored frame on a servo's limit is built and parsed back; one degree beyond,
    both refuse it, naming the servo and its limits."""
    lo, hi = LIMITS[servo]
    name = PAPAMAN.servos[servo].name
    wide = with_servo(PAPAMAN, servo, min_angle=0, max_angle=999)
    for angle in (lo, hi):
        angles = list(STAND)
        angles[servo] = angle
        image = build_image(with_stand_frame(PAPAMAN, angles))
        assert parse_image(image, PAPAMAN).motion(0).poses()[0][servo] == (angle, 2)
    for angle in (lo - 1, hi + 1):
        if angle < 0:
            continue
        angles = list(STAND)
        angles[servo] = angle
        with pytest.raises(ImageError) as e:
            build_image(with_stand_frame(PAPAMAN, angles))
        assert str(e.value) == (f"motion 'stand' frame 0: angle {angle} for servo '{name}' "
                                f"is outside its limits {lo}..{hi}")
        image = build_image(with_stand_frame(wide, angles))
        with pytest.raises(ImageError) as e:
            parse_image(image, PAPAMAN)
        assert str(e.value) == (f"motion 0 frame 0: angle {angle} for servo '{name}' "
                                f"is outside its limits {lo}..{hi}")


def test_image_pair_overflow_at_255():
    robot = with_servo(PAPAMAN, 0, max_angle=999)
    motions = tuple(m.model_copy(update={"frames": (
        Frame(angles=(505,) + (90,) * 11, speed=25),)}) if m.name == "stand" else m
        for m in robot.motions)
    image = build_image(variant(robot, "central", motions=motions))
    assert parse_image(image, robot).motion(0).poses()[0][0] == (505, 25)
    motions = tuple(m.model_copy(update={"frames": (
        Frame(angles=(600,) + (90,) * 11, speed=25),)}) if m.name == "stand" else m
        for m in robot.motions)
    with pytest.raises(ImageError, match="encodes to high byte 256, more than 255"):
        build_image(variant(robot, "central", motions=motions))


# -- the reaction's comparison ---------------------------------------------------------

@pytest.mark.parametrize("diff, tipping", [(401, True), (400, False), (399, False),
                                          (-401, True), (-400, False), (0, False)])
def test_reaction_threshold(diff, tipping):
    """|sum(a) - sum(b)| > threshold, from both sides, fires after exactly ``samples``."""
    r = BalanceReaction("r", [0, 1], [2, 3], threshold=400, samples=3, poll_ticks=5,
                        motion=4)
    values = [100, 0, 100, 0]
    values[0 if diff > 0 else 2] += abs(diff)
    assert [r.sample(values) for _ in range(4)] == \
        ([False, False, True, False] if tipping else [False] * 4)
    assert r.count == (1 if tipping else 0)


def test_reaction_polls_on_multiples_of_its_period_unless_its_motion_plays():
    r = BalanceReaction("r", [0], [1], threshold=0, samples=1, poll_ticks=5, motion=4)
    assert [t for t in range(1, 21) if r.due(t, None)] == [5, 10, 15, 20]
    assert r.due(5, 3) and not r.due(5, 4)
