"""Scenarios driving the balance reaction, and injected faults: errors, never a hang."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from esair_min.emulator import Emulator, Faults
from esair_min.emulator.papaman.actuator import encode
from esair_min.errors import EsairError
from esair_min.core.protocol import parse_reply
from esair_min.core.trace import TraceWriter
from tests.support.board_lines import READY_BAD, READY_OK, READY_OK_T, VERSION_BAD_T

ROOT = Path(__file__).resolve().parents[2]
FIX = ROOT / "tests" / "fixtures" / "scenarios"


def tx_lines(tw: TraceWriter) -> list[tuple[int, str]]:
    """(tick, text) of every line the board sent."""
    out, tick = [], 0
    for line in tw.lines:
        if line.startswith("T "):
            tick = int(line[2:])
        elif line.startswith("TX "):
            out.append((tick, bytes.fromhex(line[3:]).decode().rstrip("\r\n")))
    return out


# -- scenarios and the balance reaction --------------------------------------------------

@pytest.mark.parametrize("scenario", ["push", str(FIX / "push.csv")])
def test_push_fires_balance_within_the_configured_ticks(robot, scenario):
    tw = TraceWriter()
    emu = Emulator(robot, scenario=scenario, trace=tw)
    emu.run_for(1.05)
    emu.write(b"PLY03\r\n")                   # a dance is playing when the push comes
    emu.run_for(0.2)
    fired = [t for t, text in tx_lines(tw) if text == "!R auto_balance"]
    assert fired, "the push did not fire the reaction"
    reaction = robot.central.reactions[0]
    onset = math.ceil(1.100 / emu.tick_s)     # first tick that sees the tipping readings
    assert 0 <= fired[0] - onset <= reaction.samples * reaction.poll_ticks
    assert emu.playing == 4                  # balance pre-empted the dance
    # the next actuator write, one tick later, is the balance motion's first frame
    lines = tw.lines
    at = lines.index("TX " + b"!R auto_balance\r\n".hex().upper())
    w = next(line for line in lines[at:] if line.startswith("W 10"))
    frame = robot.motion("balance").frames[0]
    expected = bytes([0]) + b"".join(bytes(encode(a, frame.speed)) for a in frame.angles)
    assert w == f"W 10 {expected.hex().upper()} ACK"
    emu.run_for(0.05)
    assert emu.servo_angles == list(robot.motion("balance").frames[-1].angles)


def test_quiet_never_fires(robot):
    tw = TraceWriter()
    emu = Emulator(robot, scenario="quiet", trace=tw)
    emu.run_for(3.0)
    assert not [t for t, text in tx_lines(tw) if text.startswith("!R ")]
    assert emu.sensor_values == (512,) * 8
    assert emu.command("s")[-1] == "OK 512,512,512,512,512,512,512,512"


def test_scenario_readings_reach_the_s_command(robot):
    emu = Emulator(robot, scenario="push")
    emu.run_for(1.2)
    assert emu.command("s")[-1] == "OK 680,680,680,680,340,340,340,340"


# -- faults ------------------------------------------------------------------------------

def test_actuator_nack(robot):
    emu = Emulator(robot, faults=Faults(actuator_nack=True))
    emu.settle()
    assert emu.command("t") == [READY_OK_T, "E10 no answer on i2c"]
    assert emu.command("oab100") == ["E10 no answer on i2c"]
    assert emu.command("PLY03") == ["OK"]           # the first frame is read, not written
    emu.run_for(0.05)
    assert emu.read() == b"!E10 no answer on i2c\r\n"
    assert emu.playing is None
    assert emu.command("v")[0].startswith("OK esair-min/1")      # still working
    assert emu.servo_angles == [90] * 12
    assert list(emu.errors) == ["E10 no answer on i2c"] * 2 + ["!E10 no answer on i2c"]


def test_sensor_board_absent(robot):
    emu = Emulator(robot, faults=Faults(sensor_absent=True))
    emu.run_for(1.0)
    assert emu.read() == READY_OK + b"!E10 no answer on i2c\r\n"
    assert emu.command("s") == ["E10 no answer on i2c"]
    emu.run_for(1.0)
    assert emu.read() == b""                        # the notice is sent once
    assert emu.command("t") == ["OK"]


def test_corrupt_eeprom(robot):
    emu = Emulator(robot, faults=Faults(corrupt_eeprom=True, seed=3))
    assert emu.corrupted_at is not None and emu.corrupted_at >= 8
    emu.settle()
    assert emu.read() == READY_BAD
    assert emu.command("PLY03") == ["E09 motion image invalid"]
    assert emu.command("DNC") == ["E09 motion image invalid"]
    assert emu.command("t") == ["OK"]
    assert emu.command("v") == [VERSION_BAD_T]


def test_fault_at_run_time_and_recovery(robot):
    emu = Emulator(robot)
    emu.settle()
    emu.read()
    emu.set_fault("actuator", True)
    assert emu.command("t") == ["E10 no answer on i2c"]
    emu.set_fault("actuator", False)
    assert emu.command("t") == ["OK"]
    with pytest.raises(EsairError) as exc:
        emu.set_fault("motor", True)
    assert str(exc.value) == "no device 'motor' to fault (actuator, sensor, eeprom or bus)"


def test_stuck_bus_times_out_like_the_pic(robot):
    """SCL held low: every transfer fails after the PIC master's timeout and bus clear
    (8200 + 725 cycles at 20 MHz = 1.785 ms, measured in gpsim), commands that do not
    need the bus answer as usual, and releasing the bus brings everything back."""
    emu = Emulator(robot)
    emu.settle()
    emu.read()
    emu.set_fault("bus", True)
    emu.write(b"s\r\n")                     # the sensor read at once: one timeout
    emu.run_until(emu.clock.now + 2 * emu.uart.byte_ns)        # the CR is in
    assert emu.bus.busy_until - emu.bus.last_start == 1_785_000
    emu.run_for(0.1)
    # the reply, then the balance reaction's poll fails too (one notice)
    assert emu.read() == b"E10 no answer on i2c\r\n!E10 no answer on i2c\r\n"
    assert emu.command("v")[-1].startswith("OK esair-min/1")
    assert emu.command("t") == ["E10 no answer on i2c"]
    assert emu.command("PLY03") == ["E10 no answer on i2c"]
    emu.set_fault("bus", False)
    assert emu.command("t") == ["OK"]
    assert emu.command("PLY03") == ["OK"]


def test_stuck_bus_from_reset_fails_the_image_check(robot):
    emu = Emulator(robot, faults=Faults(bus_stuck=True))
    emu.settle()
    # the boot notice, and (its tick fell while it was sent) the balance poll's notice
    assert emu.read() == READY_BAD + b"!E10 no answer on i2c\r\n"
    assert emu.command("PLY01") == ["E09 motion image invalid"]


def test_noise_gets_error_replies_and_never_hangs(robot):
    emu = Emulator(robot, faults=Faults(noise_per_s=40, seed=7))
    emu.settle()
    emu.read()
    chunk = ["v", "t", "s", "oab100", "x"]       # 20 bytes in, 117 bytes of replies out
    lines = chunk * 20
    for _ in range(20):                          # paced so the replies can leave
        emu.write(b"".join(ln.encode() + b"\r\n" for ln in chunk))
        emu.run_for(0.25)
    emu.run_for(2.0)                             # ~80 bytes of noise, no line end
    replies = [r for r in emu.read().decode("latin-1").split("\r\n")[:-1]]
    parsed = [parse_reply(r) for r in replies]          # every line is a real reply
    answers = [p for p in parsed if p.counts]
    oks = [p for p in answers if p.kind == "ok"]
    errors = [p for p in answers if p.kind == "error"]
    assert errors, "noise at 40 B/s should corrupt some lines"
    assert len(oks) >= len(lines) // 2
    # garbage since the last line end is one overlong line; a line end resyncs
    assert emu.command("") == ["E02 line too long"]
    # still answering: CR LF first ends whatever noise came since the last reply (a
    # noise byte may still land inside the `v` line: one of three gets through)
    answers = []
    for _ in range(3):
        emu.write(b"\r\nv\r\n")
        emu.run_for(0.2)
        answers += emu.read().decode("latin-1").split("\r\n")[:-1]
    assert any(a.startswith("OK esair-min/1") for a in answers), answers


def test_noise_is_seeded(robot):
    def run(seed):
        emu = Emulator(robot, faults=Faults(noise_per_s=100, seed=seed))
        emu.write(b"v\r\n" * 50)
        emu.run_for(2.0)
        return emu.read()

    assert run(1) == run(1) != run(2)


def test_negative_noise_is_refused():
    with pytest.raises(EsairError) as exc:
        Faults(noise_per_s=-1)
    assert str(exc.value) == "noise rate -1 must be 0 or more bytes per second"


def test_fault_description():
    assert Faults().describe() == "none"
    assert Faults(True, True, True, 5, 2).describe() == (
        "actuator NACKs, sensor board absent, corrupt EEPROM, line noise 5 B/s (seed 2)")
