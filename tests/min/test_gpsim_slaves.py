"""The actuator and sensor boards' PIC I2C slave firmware under a real I2C master.

gpsim runs one firmware at a time; :mod:`esair_min.pic.gpsim_i2c` drives SCL and SDA from
Python (pull-up modules on the bus nodes, the pins read back with ``portc``), so the
slave code that answers the central board runs for real: frames written and read back
over I2C, servo pulses measured, ADC readings read as the register map, and frames
written back to back while the actuator's PWM interrupt is at its busiest.

Needs the toolchain (scripts/install-toolchain.sh): without it these tests FAIL with the
install hint. Figures measured when written are in docs/toolchain.md ("I2C master").
"""

from __future__ import annotations

import re
from contextlib import contextmanager
from pathlib import Path

import pytest

from esair_min.pic import gpsim_servo
from esair_min.pic.gpsim_harness import _gpsim_pin
from esair_min.pic.gpsim_i2c import GpsimSession, I2cBusError, I2cMaster, I2cTiming
from esair_min.pic.gpsim_wave import read_edges
from esair_min.model.hardware import ADC_PINS
from esair_min.core.protocol import encode_pair
from esair_min.pic.toolchain import ToolchainError

pytestmark = pytest.mark.gpsim

PULSE_ERROR = 0.01           # servo pulse width vs the commanded (clamped) angle
SETTLE = 150_000             # cycles: start-up and a first PWM frame (30 ms)
FRAME_WRITE = 12_400         # cycles at 100 kHz: 26 bytes, START..STOP
STRETCH_MAX = 40             # cycles per read byte (CKP set by the ISR)
_REG_RE = re.compile(r"= \$([0-9a-fA-F]+) =")     # gpsim: REG230[...] = $00 = 0b00000000
I2Q_BYTES = 32               # the actuator's I2C queue (hal_pic.c.j2: i2q_bytes)


def _frame(robot, angles, speed=0) -> bytes:
    out = bytearray()
    for angle in angles:
        out += bytes(encode_pair(angle, speed))
    return bytes(out)


def _ram(session, addresses: list[int]) -> bytes:
    """Bytes read from the PIC's RAM (no cycle passes)."""
    out = session.command(*(f"reg({a:#x})" for a in addresses))
    values = [int(m.group(1), 16) for m in map(_REG_RE.search, out) if m]
    assert len(values) == len(addresses), out
    return bytes(values)


def _slave_state(session, map_text: str, n: int) -> tuple[bytes, bytes, int]:
    """The actuator slave's register map, the written bytes still in its queue
    (``i2q``: I2Q_BYTES {status, byte} pairs from ``i2q_out`` to ``i2q_in``) and its
    register pointer."""
    names = ("regs", "i2q", "i2q_in", "i2q_out", "reg_ptr")
    at = {name: int(m.group(1), 16) for name in names
          if (m := re.search(rf"^\s*_{name}\s+0x([0-9a-fA-F]+)\s+data\b", map_text, re.M))}
    got = _ram(session, [at["regs"] + i for i in range(n)]
               + [at["i2q_in"], at["i2q_out"], at["reg_ptr"]]
               + [at["i2q"] + i for i in range(I2Q_BYTES)])
    regs, (q_in, q_out, ptr), queue = got[:n], got[n:n + 3], got[n + 3:]
    pairs = ((q_in - q_out) % I2Q_BYTES) // 2
    return regs, bytes(queue[(q_out + 2 * i + 1) % I2Q_BYTES] for i in range(pairs)), ptr


@contextmanager
def _bus(cod: Path, robot, board, workdir: Path, speed_hz: int | None = None):
    """A gpsim session on ``cod`` with the master attached: (session, master)."""
    cps = board.mcu.clock_hz // 4
    with GpsimSession(workdir, timeout=120).start(cod, board.mcu.clock_hz) as session:
        master = I2cMaster(session, I2cTiming.for_speed(speed_hz or board.i2c.speed_hz, cps))
        yield session, master.attach()


@pytest.fixture(scope="module")
def actuator_cod(pic_firmware):
    return pic_firmware("actuator") / "build-pic" / "firmware.cod"


@pytest.fixture(scope="module")
def sensor_cod(pic_firmware):
    return pic_firmware("sensor") / "build-pic" / "firmware.cod"


# -- (a) a frame over I2C, read back, then the pulses --------------------------------

def test_actuator_frame_written_read_back_and_played(robot, actuator_cod, tmp_path):
    servos, address = robot.servos, robot.actuator.i2c.address
    # inside the limits, spread; and four targets outside them, clamped by the firmware
    angles = [s.min_angle + (s.max_angle - s.min_angle) * (k + 1) // (len(servos) + 1)
              for k, s in enumerate(servos)]
    outside = {0: servos[0].max_angle + 50, 3: 999, 9: max(servos[9].min_angle - 25, 0),
               11: 250}
    for i, a in outside.items():
        angles[i] = a
        assert not servos[i].min_angle <= a <= servos[i].max_angle
    frame = _frame(robot, angles)
    with _bus(actuator_cod, robot, robot.actuator, tmp_path) as (session, master):
        session.command(*gpsim_servo.recorder_lines(robot))
        session.run_to(SETTLE)
        start = session.now
        assert master.write_registers(address, 0, frame) == [True] * (len(frame) + 2)
        write_cycles = session.now - start
        assert master.stretches == []                     # a written byte is never held
        assert master.read_registers(address, 0, len(frame)) == frame
        # the slave holds SCL after the read address and each ACKed byte until its ISR
        # has put the next byte in SSPBUF and set CKP
        held = [c for _, c in master.stretches]
        assert len(held) == len(frame) and 0 < min(held) <= max(held) <= STRETCH_MAX, held
        latch = session.now
        session.run_to(latch + 2, "PSY.voltage = 0.0")
        session.run_to(latch + gpsim_servo.RECORD_CYCLES,
                       after=tuple(gpsim_servo.flush_lines(robot)))
    assert 26 * 9 * master.timing.bit < write_cycles <= FRAME_WRITE
    pulses = gpsim_servo.read_pulses(robot, angles, tmp_path, latch)
    report = "\n".join(f"servo {p.index}: {p.angle} deg, expected {p.expected_us:.0f} us, "
                       f"measured {p.measured_us:.1f} us ({p.error:+.2%})" for p in pulses)
    assert all(abs(p.error) <= PULSE_ERROR for p in pulses), report
    for i, a in outside.items():          # unclamped, the width would be far off
        s = servos[i]
        raw = s.pulse_min_us + (s.pulse_max_us - s.pulse_min_us) * a / 180
        assert abs(pulses[i].measured_us - raw) > 0.05 * raw, report


# -- (b) the sensor board's ADC readings as its register map --------------------------

def test_sensor_readings_over_i2c(robot, sensor_cod, tmp_path):
    board = robot.sensor_board
    volts = [0.0, 1.0, 2.5, 3.3, 4.99, 0.3, 5.0, 1.7]
    later = [5.0, 0.0, 0.01, 2.0, 4.0, 3.0, 0.5, 4.5]
    sensors = robot.sensors
    with _bus(sensor_cod, robot, board, tmp_path) as (session, master):
        for sensor, v in zip(sensors, volts):
            name = f"PAN{sensor.channel}"
            session.command(f"module load pullup {name}", f"node nan{sensor.channel}",
                            f"attach nan{sensor.channel} {_gpsim_pin(ADC_PINS[sensor.channel])} "
                            f"{name}.pin", f"{name}.voltage = {v}")
        readings = []
        for values in (volts, later):
            session.run_to(session.now + 100_000, *(f"PAN{s.channel}.voltage = {v}"
                                                    for s, v in zip(sensors, values)))
            data = master.read_registers(board.i2c.address, 0, 2 * len(sensors))
            assert all(data[2 * i + 1] <= 3 for i in range(len(sensors))), data.hex()
            readings.append([data[2 * i] | data[2 * i + 1] << 8 for i in range(len(sensors))])
    for got, values in zip(readings, (volts, later)):
        want = [round(v / 5 * 1023) for v in values]
        assert all(abs(g - w) <= 1 for g, w in zip(got, want)), (got, want)


# -- (c) frames back to back while the PWM interrupt is busiest -----------------------

def _busy_angles(servos) -> list[int]:
    """Pulse ends 2 degrees apart (55 Timer1 counts: nearer than PWM_NEAR, 80, so the
    high-priority ISR waits in line for all twelve edges, ~1 200 cycles)."""
    low = max(s.min_angle for s in servos)
    angles = [low + 2 * k for k in range(len(servos))]
    assert all(s.min_angle <= a <= s.max_angle for s, a in zip(servos, angles))
    return angles


@pytest.mark.parametrize("speed_hz", ["robot", 400_000])
def test_back_to_back_frames_while_the_pwm_is_busiest(robot, actuator_cod, tmp_path, speed_hz):
    """Frames written back to back across the PWM interrupt's longest in-line wait
    (~1 300 cycles, three 100 kHz bytes, eleven at 400 kHz): the PWM ISR moves each
    written byte from SSPBUF into the slave's queue while it waits, so every byte is
    ACKed, the map read back is the last frame and the pulses stay within 1 %.
    (Before the queue: a byte ending in the wait overflowed SSPBUF and was NACKed, and
    at 400 kHz every frame was NACKed at its second data byte; docs/toolchain.md.)"""
    servos, address = robot.servos, robot.actuator.i2c.address
    speed = robot.actuator.i2c.speed_hz if speed_hz == "robot" else speed_hz
    cps = robot.actuator.mcu.clock_hz // 4
    with _bus(actuator_cod, robot, robot.actuator, tmp_path, 100_000) as (session, master):
        session.command(*gpsim_servo.recorder_lines(robot))
        session.run_to(SETTLE)
        busy = _frame(robot, _busy_angles(servos))
        assert all(master.write_registers(address, 0, busy))
        session.run_to(session.now + 2, "PSY.voltage = 0.0")
        session.run_to(session.now + 150_000,
                       after=tuple(gpsim_servo.flush_lines(robot, then="b")))
        falls = sorted(c for s in servos for c, v in read_edges(tmp_path / f"servo{s.index}.txt")
                       if v == 0)
        rises = [c for c, v in read_edges(tmp_path / "servo0.txt") if v == 1]
        period = rises[-1] - rises[-2]
        # two frames on: the recording b<i> then holds the whole pulse (rise, busy falls)
        chain = (falls[-len(servos)] + 2 * period, falls[-1] + 2 * period)
        state = bytearray(master.read_registers(address, 0, len(busy)))
        master.timing = I2cTiming.for_speed(speed, cps)
        span = (len(busy) + 2) * 9 * master.timing.bit
        map_text = (actuator_cod.parent / "firmware.map").read_text()
        session.run_to(chain[0] - 2 * span)
        results, maps = [], []
        while session.now < chain[1] + span:
            frame = _frame(robot, [s.min_angle + (7 * len(results) + 3 * s.index) % 40
                                   for s in servos], speed=1)
            begin = session.now
            prev = bytes(state)
            acks = master.write_registers(address, 0, frame)
            kept = sum(acks[2:]) if acks[:2] == [True, True] else 0
            state[:kept] = frame[:kept]
            results.append((begin, session.now, acks))
            maps.append((prev, frame, *_slave_state(session, map_text, len(frame))))
        master.timing = I2cTiming.for_speed(100_000, cps)
        session.run_to(session.now + 1000)
        back = master.read_registers(address, 0, len(busy))
        session.command(*gpsim_servo.flush_lines(robot))
    edges = sorted(c for s in servos for c, _ in read_edges(tmp_path / f"b{s.index}.txt"))
    hit = [any(b - 200 <= e <= end for e in edges) for b, end, _ in results]
    report = "\n".join(f"{b}..{end}: {''.join('A' if x else 'N' for x in acks)}"
                       f"{'  (PWM edges)' if h else ''}" for (b, end, acks), h in zip(results, hit))
    assert any(b <= chain[0] <= end for b, end, _ in results), report   # the chain was hit
    assert all(acks == [True] * (len(busy) + 2) for _, _, acks in results), report
    assert bytes(state) == back == frame, report                        # the last frame
    # right after each STOP: the frame in order, in the map or still in the queue (and
    # the last byte maybe still in SSPBUF)
    for prev, sent, regs, queued, ptr in maps:
        q = len(queued)
        assert any(regs == sent[:k] + prev[k:] and queued == sent[k:k + q]
                   and ptr == k % len(sent) for k in (len(sent) - q, len(sent) - q - 1)), \
            (prev.hex(), sent.hex(), regs.hex(), queued.hex(), ptr, report)
    cps_us = cps / 1e6
    errors = []
    for s, angle in zip(servos, _busy_angles(servos)):     # the pulses during the writes
        b_edges = read_edges(tmp_path / f"b{s.index}.txt")[1:]    # not the level at start
        widths = [(f[0] - r[0]) / cps_us for r, f in zip(b_edges, b_edges[1:])
                  if r[1] == 1 and f[1] == 0]
        want = gpsim_servo.expected_us(s, angle)
        assert widths, f"servo {s.index}: no pulse during the writes"
        errors.append(max(abs(w - want) / want for w in widths))
    assert max(errors) <= PULSE_ERROR, (errors, report)


# -- the session and the master on their own -----------------------------------------

def test_timing_keeps_the_minimum_times():
    std = I2cTiming.for_speed(100_000, 5_000_000)
    assert (std.low, std.high, std.bit) == (25, 25, 50)      # tLOW 4.7 us, tHIGH 4.0 us
    assert (std.su_sta, std.hd_sta, std.su_sto, std.buf, std.hd_dat) == (24, 20, 20, 24, 2)
    fast = I2cTiming.for_speed(400_000, 5_000_000)
    assert (fast.low, fast.high, fast.bit) == (7, 6, 13)      # tLOW 1.3 us, tHIGH 0.6 us
    with pytest.raises(ToolchainError, match=r"I2C speed 1000000 Hz: the master does "
                                             r"1 \.\. 400000"):
        I2cTiming.for_speed(1_000_000, 5_000_000)


def test_missing_slave_and_stuck_lines_are_errors(robot, sensor_cod, tmp_path):
    with _bus(sensor_cod, robot, robot.sensor_board, tmp_path) as (session, master):
        session.run_to(20_000)
        assert master.write_registers(0x7F, 0, b"\x01") == [False]
        with pytest.raises(I2cBusError, match="no ACK from 0x7F for the address"):
            master.read_registers(0x7F, 0, 2)
        session.command("module load pullup PSTUCK", "PSTUCK.resistance = 100",
                        "PSTUCK.voltage = 0.0", "attach nsda PSTUCK.pin",
                        "module load pullup PHOLD", "PHOLD.resistance = 100",
                        "PHOLD.voltage = 5.0", "attach nscl PHOLD.pin")
        with pytest.raises(I2cBusError, match=r"bus not idle at cycle \d+ \(SCL=1, SDA=0\): "
                                              "cannot send START"):
            master.start()
        master.stretch_limit = 300
        session.command("PSTUCK.voltage = 5.0")
        master.start()
        session.command("PSTUCK.voltage = 0.0")
        with pytest.raises(I2cBusError, match=r"SDA held low at cycle \d+: cannot send a "
                                              "repeated START"):
            master.repeated_start()
        with pytest.raises(I2cBusError, match=r"bus not released after STOP at cycle \d+ "
                                              r"\(SCL=1, SDA=0\)"):
            master.stop()
        session.command("PSTUCK.resistance = 10000000")
        master.start()
        session.command("PHOLD.voltage = 0.0")
        with pytest.raises(I2cBusError, match=r"SCL held low for \d+ cycles after the master "
                                              r"released it at cycle \d+ \(limit 300\): a "
                                              "slave stretches the clock without end or the "
                                              "line is stuck low"):
            master.write(robot.sensor_board.i2c.address << 1)


def test_session_errors_name_the_cause_and_end_gpsim(robot, sensor_cod, tmp_path):
    board = robot.sensor_board
    with GpsimSession(tmp_path, timeout=60).start(sensor_cod, board.mcu.clock_hz) as s:
        with pytest.raises(ToolchainError, match=r"gpsim rejected a command \(nosuch\): "
                                                 r"\*\*\*ERROR"):
            s.command("nosuch")
        with pytest.raises(ToolchainError, match="gpsim session is not running"):
            s.command("cycles")
    with GpsimSession(tmp_path, timeout=60).start(sensor_cod, board.mcu.clock_hz) as s:
        s.command("break e _hal_idle")           # a stop that is not the cycle asked for
        with pytest.raises(ToolchainError, match=r"gpsim did not stop where expected "
                                                 r"\(cycles \[100000\]\)"):
            s.run_to(100_000)
    with (GpsimSession(tmp_path, timeout=60).start(sensor_cod, board.mcu.clock_hz) as s,
          pytest.raises(ToolchainError, match="gpsim exited during: quit")):
        s.command("quit")
    with GpsimSession(tmp_path, timeout=2.0).start(sensor_cod, board.mcu.clock_hz) as s:
        with pytest.raises(ToolchainError, match=r"gpsim timed out after 2\.0 s during: "
                                                 r"break c 2000000000; run"):
            s.run_to(2_000_000_000)              # 400 s of PIC time: far beyond 2 s
        assert s._proc is None                   # killed, not left running
    with pytest.raises(ToolchainError, match=r"gpsim printed no value for 'portc'"):
        s.value("portc", ["_PORTB = 0x0"])
    with pytest.raises(ToolchainError, match="pin 'SCL' is not a port pin"):
        I2cMaster(s, I2cTiming.for_speed(100_000, 5_000_000), scl="SCL")


def test_pulse_reading_errors(robot, tmp_path):
    (tmp_path / "servo0.txt").write_text("0 0\n100 1\n")
    with pytest.raises(ToolchainError, match=r"servo 0 \(RD0\): no complete pulse in the "
                                             r"60 ms after the latch"):
        gpsim_servo.read_pulses(robot, [90] * len(robot.servos), tmp_path, 0)

    class NoActuator:
        actuator = None
    with pytest.raises(ToolchainError, match="the robot has no actuator board with a sync pin"):
        gpsim_servo.recorder_lines(NoActuator())
