"""The emulated robot in virtual time: clock, UART, I2C bus, servos, commands, tracing."""

from __future__ import annotations

from pathlib import Path

import pytest

from esair_min.emulator import Emulator, VirtualClock
from esair_min.emulator.papaman.actuator import ServoBank, decode, encode, step_toward
from esair_min.emulator.i2c import (TimedBus, bits_ns, nack_bits, write_bits,
                                    write_read_bits)
from esair_min.emulator.uart import RING_BYTES, byte_time_ns
from esair_min.core.devices import RegisterSlave, SimpleBus
from esair_min.errors import EsairError
from esair_min.core.protocol import TX_RING_TABLE as TX_RING, parse_reply
from esair_min.core.trace import TraceWriter, without_marks
from tests.support.board_lines import READY_OK, READY_OK_T, VERSION_OK, VERSION_OK_T

ROOT = Path(__file__).resolve().parents[2]


def booted(robot, **kw) -> Emulator:
    emu = Emulator(robot, **kw)
    emu.settle()
    assert emu.read() == READY_OK
    return emu


# -- the clock ---------------------------------------------------------------------------

def test_clock_runs_events_in_time_then_schedule_order():
    clock = VirtualClock()
    seen = []
    clock.schedule(30, lambda: seen.append(("c", clock.now)))
    clock.schedule(10, lambda: seen.append(("a", clock.now)))
    clock.schedule(10, lambda: seen.append(("b", clock.now)))
    assert clock.run_until(20) == 2
    assert seen == [("a", 10), ("b", 10)] and clock.now == 20
    clock.run_until(100)
    assert seen[-1] == ("c", 30) and clock.now == 100
    assert clock.next_event() is None


def test_timer2_ticks_at_the_computed_period(robot):
    emu = Emulator(robot)
    period = robot.central.timer2.period_s
    assert period == pytest.approx(8.9856e-3)
    emu.run_for(1.0)
    assert emu.ticks == int(1.0 / period)           # 111 ticks in a second
    assert emu.actuator.syncs == emu.ticks == emu.core.ticks


# -- the UART ----------------------------------------------------------------------------

def test_byte_takes_ten_bit_times(robot):
    assert byte_time_ns(9600) == 1_041_667
    emu = booted(robot)
    t0 = emu.clock.now
    lines = emu.command("v")
    assert lines == [VERSION_OK_T]
    # "v" CR in (the line ends at CR), then the reply and its CR LF out, 10 bit times each
    assert len(VERSION_OK) == 92
    assert emu.clock.now - t0 == (2 + 92) * byte_time_ns(9600)


def test_ring_overrun_answers_e12_then_recovers(robot):
    emu = booted(robot)
    for _ in range(RING_BYTES + 6):        # bytes arriving faster than the board reads
        emu.uart.receive(ord("v"))
    assert emu.uart.overrun and len(emu.uart.ring) == RING_BYTES
    emu.uart.receive(ord("\n"))            # lost too: the ring is still full
    emu.write(b"\r\nv\r\n")
    emu.run_for(0.3)
    text = emu.read().decode()
    # the 64 v's plus the end of line: one line, answered E12; then v works again
    assert text.split("\r\n")[:2] == ["E12 input overrun", VERSION_OK_T]


def test_replies_faster_than_the_line_stall_the_board_like_its_transmit_ring(robot):
    """200 `v` lines back to back: each 2-byte line asks for a 92-byte reply, so the
    replies cannot leave as fast as the lines come. As on the PIC, the superloop waits
    for room in the 96-byte transmit ring meanwhile, the receive ring overruns, and
    what waits to be sent stays bounded (it grew with every line before)."""
    emu = booted(robot)
    emu.write(b"v\r" * 200)
    end = emu.clock.now + 6_000_000_000
    peak, out = 0, b""
    while emu.clock.now < end and not emu.idle:
        emu._step(end)
        peak = max(peak, emu.uart.tx_backlog)
        out += emu.read()
    lines = (out + emu.read()).decode().split("\r\n")[:-1]
    assert emu.idle
    assert peak <= TX_RING + len(VERSION_OK) + 1   # the ring, the byte on the wire, one reply
    assert "E12 input overrun" in lines
    assert 20 <= len(lines) < 100        # most lines were lost to the overruns
    emu.write(b"\r\nv\r\n")
    emu.run_for(0.3)
    assert emu.read().endswith(VERSION_OK)


# -- the I2C bus -------------------------------------------------------------------------

def test_bus_bit_counts_match_the_thesis_comparison():
    assert write_bits(1 + 24) == 236               # one burst: register + 24 bytes
    assert write_read_bits(2, 24) == 255           # one sequential read of a frame
    assert 12 * 2 * write_bits(2) == 696           # thesis: two 3-byte writes per servo
    assert nack_bits() == 11
    assert bits_ns(236, 100_000) == 2_360_000


def test_timed_bus_accounts_time_and_nacks():
    now = [0]
    slave = RegisterSlave(0x10, 4)
    bus = TimedBus(SimpleBus([slave]), 100_000, lambda: now[0])
    assert bus.write(0x10, b"\x00\x01\x02")
    assert bus.busy_until == bits_ns(write_bits(3), 100_000)
    assert bus.write_read(0x10, b"\x00", 2) == b"\x01\x02"
    assert bus.write(0x33, b"\x00") is False               # nobody there
    assert bus.write_read(0x33, b"\x00", 2) is None
    total = write_bits(3) + write_read_bits(1, 2) + 2 * nack_bits()
    assert bus.stats.bits == total and bus.stats.nacks == 2
    assert bus.busy_until == bits_ns(write_bits(3), 100_000) + bits_ns(
        write_read_bits(1, 2), 100_000) + 2 * bits_ns(nack_bits(), 100_000)


# -- servo model -------------------------------------------------------------------------

def test_pair_encoding_and_stepping():
    assert encode(135, 3) == (35, 31) and decode(35, 31) == (135, 3)
    assert step_toward(90, 100, 4) == 94
    assert step_toward(98, 100, 4) == 100
    assert step_toward(100, 90, 0) == 90
    assert step_toward(90, 80, 3) == 87


def test_servo_bank_clamps_undecodable_or_outside_pairs(robot):
    bank = ServoBank(robot.servos)
    regs = bytearray(24)
    for i, s in enumerate(robot.servos):
        regs[2 * i], regs[2 * i + 1] = encode(s.stand_angle, 0)
    regs[0], regs[1] = encode(170, 0)          # servo 0 max is 120
    regs[2], regs[3] = 150, 0                  # low >= 100 does not decode
    bank.latch(regs)
    assert bank.targets[0] == 120 and bank.bad_pairs == 2
    bank.step()
    assert bank.angles[0] == 120


def test_motor_command_moves_servo_at_its_speed(robot):
    emu = booted(robot)
    assert emu.command("oaf120") == ["OK"]           # motor a, speed f = 5, 120 degrees
    assert emu.core.targets[0] == 120
    # latched at the sync edge after the write (the reply came at that tick), then 5
    # degrees per tick
    assert emu.servo_angles[0] == 95
    seen = []
    for _ in range(8):
        emu.run_until(emu._tick_time(emu.ticks + 1))
        seen.append(emu.servo_angles[0])
    assert seen == [100, 105, 110, 115, 120, 120, 120, 120]
    assert emu.servo_targets[0] == 120


def test_angles_and_speeds_commands(robot):
    emu = booted(robot)
    assert emu.command("a" + "000" * 12) == ["OK"]          # every servo at once
    assert emu.command("c" + "l" * 12) == ["E04 outside limits"]     # 'l' = 180 degrees
    line = "c" + "".join("8" if i != 3 else "." for i in range(12))  # '8' = 24 deg
    assert emu.command(line) == ["E04 outside limits"]
    assert emu.command("c" + "N" * 12) == ["OK"]              # 'N' = 3*30 = 90 degrees
    assert emu.command("c" + "P" + "." * 11) == ["OK"]        # 'P' = 96 degrees on servo a
    emu.run_for(0.03)
    assert emu.servo_angles[0] == 96 and emu.servo_angles[1:] == [90] * 11


def test_stand_sit_dance_stop(robot):
    emu = booted(robot)
    assert emu.command("SIT") == ["OK"]
    assert emu.command("t") == ["E07 busy"]
    assert emu.command("x") == ["OK"]
    assert emu.playing is None
    assert emu.command("t") == ["OK"]
    assert emu.command("DNC") == ["OK"]
    assert emu.playing == 3
    emu.run_for(0.5)
    assert emu.playing is None
    last = robot.motion("dance").frames[-1].angles
    assert emu.servo_angles == list(last)              # the dance's last pose


def test_every_documented_reply(robot):
    emu = booted(robot)
    cases = {
        "zz": "E01 unknown command",
        "v" * 41: "E02 line too long",
        "oab1x0": "E03 bad argument",
        "oab170": "E04 outside limits",
        "oaz999": "E04 outside limits",
        "PLY42": "E08 no such motion",
        "t*75": "E06 bad checksum",
        "t*74": "OK",
        "t\x01": "E13 bad character",
        "s": "OK 512,512,512,512,512,512,512,512",
    }
    for line, reply in cases.items():
        assert emu.command(line) == [reply], line


# -- one reply per line at line rate -----------------------------------------------------

def test_back_to_back_commands_each_get_one_reply_in_order(robot):
    emu = booted(robot)
    # 12 lines in one write: their replies (150 bytes) outgrow the lines (104 bytes),
    # but the transmit ring absorbs the difference; three times over it would not
    # (see the test above: the receive ring overruns, on the PIC in gpsim too)
    lines = ["t", "oab100", "v", "s", "zz", "a" + "002" * 12, "c" + "N" * 12, "x",
             "oab095", "PLY09", "t", "oal100"]
    emu.write(b"".join(ln.encode() + b"\r\n" for ln in lines))
    emu.run_for(2.0)
    got = emu.read().decode().split("\r\n")[:-1]
    assert len(got) == len(lines)
    expected = {"t": "OK", "v": "OK esair-min", "s": "OK 512", "zz": "E01", "x": "OK",
                "PLY09": "E08"}
    for line, reply in zip(lines, got):
        assert reply.startswith(expected.get(line, "OK")), (line, reply)
        assert parse_reply(reply).counts
    assert emu.uart.overruns == 0


# -- the frame player on the bus ---------------------------------------------------------

def test_dance_plays_one_frame_per_tick_in_one_burst(robot):
    tw = TraceWriter()
    emu = booted(robot, trace=tw)
    assert emu.command("PLY03") == ["OK"]
    emu.run_for(0.5)
    lines = without_marks(tw.lines)
    ticks: dict[int, list[str]] = {}
    tick = 0
    for line in lines:
        if line.startswith("T "):
            tick = int(line[2:])
        elif line.startswith(("W 10", "R 50")):
            ticks.setdefault(tick, []).append(line)
    writes = {t: [x for x in v if x.startswith("W 10")] for t, v in ticks.items()}
    frame_ticks = sorted(t for t, w in writes.items() if w)
    assert len(frame_ticks) == 32                                   # 32 frames
    assert frame_ticks == list(range(frame_ticks[0], frame_ticks[0] + 32))  # one per tick
    for t in frame_ticks:
        (w,) = writes[t]                                            # one burst per frame
        assert w.startswith("W 10 00") and len(w.split()[2]) == 2 * 25
    reads = [x for v in ticks.values() for x in v if x.startswith("R 50")]
    assert all(r.split()[3] == "24" for r in reads[-32:])          # one sequential read


def test_trace_marks_follow_bus_time(robot):
    tw = TraceWriter()
    emu = booted(robot, trace=tw)
    emu.command("t")
    lines = tw.lines
    def mark_before(k: int) -> int:
        return int(next(lines[m] for m in range(k, 0, -1) if lines[m].startswith("@ "))[2:])

    i = next(k for k, ln in enumerate(lines) if ln.startswith("W 10"))
    j = next(k for k in range(i, len(lines)) if lines[k] == "TX 4F4B0D0A")
    t_write, t_reply = mark_before(i), mark_before(j)
    # the reply leaves when the frame write ends: 236 bits at 100 kHz (2.36 ms) plus the
    # PIC master's overhead (esair_min.model.mcu.BusOverhead): 2.535 ms, as in gpsim
    assert t_reply - t_write == 2535


def test_same_input_same_trace(robot):
    def run():
        tw = TraceWriter()
        emu = booted(robot, trace=tw, scenario="push")
        emu.write(b"PLY03\r\nv\r\noab100\r\ns\r\n")
        emu.run_for(2.0)
        return tw.lines

    assert run() == run()


def test_emulator_refuses_a_central_board_without_uart(robot):
    import dataclasses

    central = robot.central.model_copy(update={"uart": None})
    other = tuple(b for b in robot.boards if b.role != "central")
    bad = dataclasses.replace(robot, boards=(central,) + other)
    with pytest.raises(EsairError) as exc:
        Emulator(bad)
    assert str(exc.value) == "the central board needs uart: and tick: to be emulated"


def test_bytes_sent_during_the_boot_image_check_overrun_the_ring(robot):
    emu = Emulator(robot)                  # at reset: 40 EEPROM reads, about 126 ms
    assert emu.bus.busy_until == pytest.approx(0.1259e9, rel=0.01)    # (115 ms on the wire)
    emu.write(b"v\r\n" * 42)               # 126 bytes at once: 131 ms on the line
    emu.run_for(4.0)
    replies = emu.read().decode().split("\r\n")
    assert replies[0] == READY_OK_T
    # the ring held 21 whole lines and the 22nd's "v" when bytes were lost: those 21
    # are answered, then the damaged rest once (the loss swallowed whole lines)
    assert all(r.startswith("OK esair-min/1") for r in replies[1:22])
    assert replies[22:] == ["E12 input overrun", ""]
    assert emu.uart.overruns > 0
    # the burst's last line end got in after the loss: its E12 answered all of the
    # damage, no loss is pending, and the next lines are answered as usual
    assert not emu.uart.overrun
    emu.write(b"v\r\nv\r\n")
    emu.run_for(0.3)
    assert emu.read().decode().split("\r\n") == [VERSION_OK_T, VERSION_OK_T, ""]


def test_live_view_shows_servos_sensors_lines_and_errors(robot):
    from rich.console import Console

    from esair_min.emulator.papaman.view import Motion, render
    from esair_min.emulator.ptyserver import PtyPort

    emu = booted(robot, scenario="push", transcript=True)
    motion = Motion(emu)
    emu.command("oaf120")
    emu.command("zz")
    emu.run_for(1.2)
    console = Console(record=True, width=140, color_system=None)
    console.print(render(emu, motion, PtyPort("/dev/pts/9"), 140, 40))
    text = console.export_text()
    assert "papaman /dev/pts/9" in text and "tick " in text
    assert "  oaf120 → OK" in text and "  zz     → E01 unknown command" in text
    assert "l_hip_yaw" in text and "r_ankle_roll" in text          # servos
    assert "l_toe_in" in text and "680" in text                    # sensors, pushed
    assert "oaf120" in text and "E01 unknown command" in text      # lines
    assert "errors: E01 unknown command" in text


def test_line_views_split_cr_lf_and_crlf_across_chunks():
    from esair_min.emulator.papaman.robot_sim import _Lines

    lines = _Lines(3)
    assert lines.feed(b"ab\r") == ["ab"]
    assert lines.feed(b"\ncd\n\nef") == ["cd"]          # CR LF split: one line end
    assert lines.feed(b"\r\r\n") == ["ef"]
    assert lines.feed(b"g\nh") == ["g"]
    assert list(lines.last) == ["cd", "ef", "g"] and lines.count == 4
