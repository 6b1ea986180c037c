"""STARFISH's cores in Python (issue 22): the central board's protocol, limits and
watchdog, the bytes it writes to the drive board, the drive board's ramp and duty, the
omni kinematics in integers, and the ADNS-2610 model's registers and timing."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from esair_min.components.dc_motor.core import DriveCore, to_s16
from esair_min.components.omni_base.core import (WATCHDOG_NOTICE, StarfishCore, velocity_line,
                                                 wheels_line)
from esair_min.components.omni_base.kinematics import (body_velocity, matrix, wheel_speeds,
                                                       wheel_table)
from esair_min.components.optical_flow.core import (REG_DELTA_X, REG_DELTA_Y, REG_SQUAL,
                                                    Adns2610, FlowTimingError, read_deltas)
from esair_min.core.protocol import add_checksum


class Bus:
    def __init__(self, answer: bool = True):
        self.writes: list[tuple[int, bytes]] = []
        self.answer = answer

    def __call__(self, address: int, data: bytes) -> bool:
        self.writes.append((address, bytes(data)))
        return self.answer


@pytest.fixture
def core(starfish):
    bus = Bus()
    c = StarfishCore(starfish, bus, [Adns2610(), Adns2610()])
    c.bus = bus
    return c


def reply(core, line: str) -> bytes:
    return core.feed(line.encode() + b"\r\n")


def test_replies_of_every_command(core):
    assert reply(core, "v") == (b"OK esair-min/1 starfish wheels=3 flow=2 watchdog=500 "
                                b"checksum=off\r\n")
    assert reply(core, "V+0200+0000+0000") == b"OK\r\n"
    assert core.bus.writes == [(0x30, bytes([0, 0x38, 0xFF, 0x64, 0x00, 0x64, 0x00]))]
    assert reply(core, "W-0100+0050+0000") == b"OK\r\n"
    assert core.bus.writes[-1] == (0x30, bytes([0, 0x9C, 0xFF, 0x32, 0x00, 0, 0]))
    assert reply(core, "x") == b"OK\r\n"
    assert core.bus.writes[-1] == (0x30, bytes(7))
    assert reply(core, "O") == b"OK n=0 a=0,0,0 b=0,0,0\r\n"
    assert reply(core, add_checksum("V+0000+0000+0100")) == b"OK\r\n"


@pytest.mark.parametrize("line, answer", [
    ("V+0501+0000+0000", b"E04 outside limits\r\n"),      # body limit 500 mm/s
    ("V+0000-0000+3001", b"E04 outside limits\r\n"),      # omega limit 3000 mrad/s
    ("W+0601+0000+0000", b"E04 outside limits\r\n"),      # wheel limit 600 mm/s
    ("V+0500+0500+3000", b"E04 outside limits\r\n"),      # in the body limits, a wheel over
    ("V+0200+0000+000", b"E03 bad argument\r\n"),
    ("V 0200+0000+0000", b"E03 bad argument\r\n"),
    ("V+02x0+0000+0000", b"E03 bad argument\r\n"),
    ("Ox", b"E03 bad argument\r\n"),
    ("t", b"E01 unknown command\r\n"),
    ("O*00", b"E06 bad checksum\r\n"),
    ("V+0200" * 7, b"E02 line too long\r\n")                  # 42 characters,
])
def test_errors(core, line, answer):
    assert reply(core, line) == answer
    assert core.bus.writes == []                  # nothing moves on a refused line


def test_no_answer_on_the_bus(starfish):
    c = StarfishCore(starfish, Bus(answer=False), [])
    assert reply(c, "V+0100+0000+0000") == b"E10 no answer on i2c\r\n"
    assert c.commanded == [0, 0, 0]


def test_watchdog_stops_every_wheel_once(core):
    assert reply(core, "V+0100+0000+0000") == b"OK\r\n"
    ticks = core.watchdog_ticks
    assert ticks == 51                            # 500 ms of 9.9904 ms ticks, rounded up
    notices = [core.tick() for _ in range(ticks - 1)]
    assert not any(notices) and len(core.bus.writes) == 1
    assert core.tick() == WATCHDOG_NOTICE
    assert core.bus.writes[-1] == (0x30, bytes(7))
    assert [core.tick() for _ in range(200)] == [b""] * 200     # stopped: no more notices
    assert core.watchdog_stops == 1


def test_valid_commands_feed_the_watchdog_and_refused_ones_do_not(core):
    reply(core, "V+0100+0000+0000")
    for _ in range(10):
        for _ in range(40):
            assert core.tick() == b""
        assert reply(core, "O").startswith(b"OK n=")         # any valid command feeds it
    for _ in range(40):
        core.tick()
    assert reply(core, "V+0900+0000+0000") == b"E04 outside limits\r\n"
    assert b"".join(core.tick() for _ in range(11)) == WATCHDOG_NOTICE


def test_kinematics_in_integers_match_the_exact_map(starfish):
    wheels = wheel_table(sorted(starfish.board("drive").motors, key=lambda m: m.index))
    assert [(w.s, w.c, w.r) for w in wheels] == [(-16384, 0, 1966), (8192, -14189, 1966),
                                                (8192, 14189, 1966)]
    m = matrix(wheels)
    for vx, vy, w in [(200, 0, 0), (0, -300, 0), (0, 0, 3000), (123, -456, 789)]:
        got = wheel_speeds(wheels, vx, vy, w)
        exact = [row[0] * vx + row[1] * vy + row[2] * w / 1000 for row in m]
        assert all(abs(g - e) <= 1 for g, e in zip(got, exact, strict=True)), (got, exact)
        back = body_velocity(wheels, exact)
        assert back == pytest.approx((vx, vy, w / 1000), abs=1e-9)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.binary(max_size=45), max_size=8))
def test_any_input_gives_one_known_reply_per_line_and_limits_hold(starfish, chunks):
    bus = Bus()
    c = StarfishCore(starfish, bus, [])
    for chunk in chunks:
        out = c.feed(chunk.replace(b"\r", b"").replace(b"\n", b"") + b"\r\n")
        for line in out.splitlines():
            assert line.startswith((b"OK", b"E0", b"E1")), line
    for _, data in bus.writes:
        speeds = [to_s16(data[k], data[k + 1]) for k in (1, 3, 5)]
        assert all(abs(s) <= 600 for s in speeds)


@settings(max_examples=200, deadline=None)
@given(st.integers(-500, 500), st.integers(-500, 500), st.integers(-3000, 3000))
def test_velocity_lines_within_limits_are_accepted_or_refused_by_the_wheel_limit(
        starfish, vx, vy, w):
    bus = Bus()
    c = StarfishCore(starfish, bus, [])
    speeds = wheel_speeds(c.wheels, vx, vy, w)
    answer = reply(c, velocity_line(vx, vy, w))
    if all(abs(s) <= 600 for s in speeds):
        assert answer == b"OK\r\n"
        assert [to_s16(bus.writes[0][1][k], bus.writes[0][1][k + 1]) for k in (1, 3, 5)] \
            == speeds
    else:
        assert answer == b"E04 outside limits\r\n" and bus.writes == []
    assert reply(c, wheels_line([0, 0, 0])) == b"OK\r\n"


def test_drive_ramps_clamps_and_sets_the_duty(starfish):
    drive = DriveCore(starfish.board("drive"))
    m = drive.motors[0]
    assert (m.limit, m.step, m.duty_q8) == (600, 20, 87)
    drive.write(0, bytes([0x58, 0x02]))           # +600 mm/s wanted
    drive.tick()
    assert (m.speed, m.duty, m.forward) == (20, 6, True)
    for _ in range(40):
        drive.tick()
    assert (m.speed, m.duty) == (600, 203)
    drive.write(0, bytes([0x00, 0x80]))           # -32768: clamped to the limit
    for _ in range(100):
        drive.tick()
    assert (m.speed, m.duty, m.forward) == (-600, 203, False)
    assert m.rim_speed == pytest.approx(-203 * m.full_speed / 255)
    drive.write(5, bytes([0x01, 0x02, 0x03]))     # auto-increment wraps at the map's end
    assert bytes(drive.regs) == bytes([0x02, 0x03, 0, 0, 0, 0x01])


def test_flow_sensor_registers_and_timing():
    s = Adns2610()
    s.move(10.0, -5.0, 0.1)                       # 100 mm/s: tracked
    dx, dy, q, t = read_deltas(s, 0)
    assert (dx, dy, q) == (127, -78, 90)          # x saturates at 127 counts, the rest stays
    assert read_deltas(s, t)[:3] == (30, 0, 90)
    assert t == 3 * (100_000 + 8_000 + 250 + 8_000)
    s.address(REG_DELTA_X, 10**9)
    with pytest.raises(FlowTimingError) as exc:
        s.data(10**9 + 99_999)
    assert str(exc.value) == "data read 99999 ns after the address; the sensor needs tSRAD = 100000 ns"
    s.address(REG_DELTA_Y, 2 * 10**9)
    s.data(2 * 10**9 + 100_000)
    with pytest.raises(FlowTimingError) as exc:
        s.address(REG_SQUAL, 2 * 10**9 + 100_100)
    assert str(exc.value) == ("address 0x04 at 2000100100 ns, before the sensor is ready at "
                              "2000100250 ns")


def test_flow_sensor_lifted_or_too_fast_loses_motion():
    s = Adns2610()
    s.lifted = True
    s.move(1.0, 0.0, 0.01)
    assert read_deltas(s, 0)[:3] == (0, 0, 0) and s.lost == 1
    s.lifted = False
    s.move(4.0, 0.0, 0.01)                        # 400 mm/s = 15.7 ips > 12 ips
    assert read_deltas(s, 10**9)[:3] == (0, 0, 90) and s.lost == 2
    s.move(3.0, 0.0, 0.01)                        # 300 mm/s: tracked
    assert read_deltas(s, 2 * 10**9)[:2] == (math.floor(3.0 * 400 / 25.4), 0)
