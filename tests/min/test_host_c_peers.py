"""Host builds of the actuator and sensor boards' generated cores (gcc, warnings as
errors, ASan/UBSan), driven by their test scripts (docs/firmware.md) and checked
against the rules of docs/protocol.md written out here in Python."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from esair_min.codegen import generate_robot

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
SANITIZE = "-fsanitize=address,undefined -fno-sanitize-recover=all"
SLOW_OK = settings(max_examples=60, deadline=None,
                   suppress_health_check=[HealthCheck.function_scoped_fixture])


@pytest.fixture(scope="module")
def boards(robot, tmp_path_factory):
    out = tmp_path_factory.mktemp("peers")
    generate_robot(robot, out)
    for role in ("actuator", "sensor"):
        proc = subprocess.run(["make", "-s", "host", f"SANITIZE={SANITIZE}"], cwd=out / role,
                              capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stdout + proc.stderr
    return out


def run(binary: Path, script: str, tmp: Path) -> list[str]:
    path = tmp / "script.txt"
    path.write_text(script)
    proc = subprocess.run([str(binary), str(path)], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout.splitlines()


# -- actuator ----------------------------------------------------------------------------

class ActuatorModel:
    """The actuator rules, independently: decode, ignore invalid pairs, clamp, step."""

    def __init__(self, servos):
        self.servos = servos
        self.regs = bytearray(b for s in servos for b in (s.stand_angle % 100,
                                                          s.stand_angle // 100 + 10 * s.default_speed))
        self.pos = [s.stand_angle for s in servos]
        self.target = list(self.pos)
        self.speed = [s.default_speed for s in servos]

    def write(self, reg: int, data: bytes) -> None:
        for b in data:
            self.regs[reg % len(self.regs)] = b
            reg += 1

    def sync(self) -> list[tuple[int, int]]:
        for i, s in enumerate(self.servos):
            low, high = self.regs[2 * i], self.regs[2 * i + 1]
            if low < 100:
                self.target[i] = min(max((high % 10) * 100 + low, s.min_angle), s.max_angle)
                self.speed[i] = high // 10
            step = self.speed[i]
            d = self.target[i] - self.pos[i]
            self.pos[i] = (self.target[i] if step == 0 or abs(d) <= step
                           else self.pos[i] + (step if d > 0 else -step))
        return [(p, s.pulse_min_us + (s.pulse_max_us - s.pulse_min_us) * p // 180)
                for p, s in zip(self.pos, self.servos)]


def parse_sync(line: str) -> list[tuple[int, int]]:
    return [tuple(int(v) for v in pair.split("/")) for pair in line.split()[2:]]


writes = st.lists(st.tuples(st.integers(0, 30), st.binary(min_size=1, max_size=30),
                            st.integers(1, 6)), min_size=1, max_size=12)


@SLOW_OK
@given(writes)
def test_actuator_clamps_and_steps(robot, boards, tmp_path, ops):
    model = ActuatorModel(robot.servos)
    script, expected = [], []
    for reg, data, syncs in ops:
        script.append(f"write {reg:X} " + " ".join(f"{b:02X}" for b in data))
        model.write(reg, data)
        script.append(f"sync {syncs}")
        expected += [model.sync() for _ in range(syncs)]
    lines = run(boards / "actuator" / "firmware_host", "\n".join(script) + "\n", tmp_path)
    got = [parse_sync(line) for line in lines if line.startswith("S ")]
    assert got == expected
    for state in got:
        for (angle, _), s in zip(state, robot.servos):
            assert s.min_angle <= angle <= s.max_angle


def test_actuator_speed_and_at_once(robot, boards, tmp_path):
    # servo 2 (l_hip_pitch, 20..160) to 150 at speed 5, servo 0 to 70 at once,
    # servo 1 gets an invalid pair (low 100) and keeps its target.
    lines = run(boards / "actuator" / "firmware_host",
                "write 0 46 00 64 00 32 33\nsync 13\nread 0 6\n", tmp_path)
    states = [parse_sync(line) for line in lines if line.startswith("S ")]
    assert [st_[2][0] for st_ in states] == [95, 100, 105, 110, 115, 120, 125, 130, 135, 140,
                                             145, 150, 150]
    assert all(st_[0][0] == 70 for st_ in states)
    assert all(st_[1][0] == 90 for st_ in states)
    assert states[-1][2][1] == 500 + 2000 * 150 // 180
    assert lines[-1] == "R 460064003233"


# -- sensor ------------------------------------------------------------------------------

@SLOW_OK
@given(st.lists(st.integers(0, 65535), min_size=8, max_size=8))
def test_sensor_registers_hold_10_bit_readings(robot, boards, tmp_path, values):
    channels = [s.channel for s in robot.sensors]
    script = [f"adc {ch} {v}" for ch, v in zip(channels, values)] + ["step 8", "read 0 16"]
    lines = run(boards / "sensor" / "firmware_host", "\n".join(script) + "\n", tmp_path)
    expected = b"".join(bytes((v & 0xFF, (v >> 8) & 3)) for v in values).hex().upper()
    assert lines == [f"R {expected}"]


def test_sensor_round_robin_and_fault(boards, tmp_path):
    lines = run(boards / "sensor" / "firmware_host",
                "adc 0 700\nadc 1 300\nstep 1\nread 0 4\nstep 1\nread 0 4\n"
                "fault adc on\nadc 0 1\nstep 8\nread 0 4\nfault adc off\nstep 6\nread 0 2\n"
                "step 1\nread 0 2\n", tmp_path)
    assert lines == ["R BC020000", "R BC022C01", "R BC022C01", "R BC02", "R 0100"]


# -- the peers' scripts are read by the shared rules (docs/trace-format.md) --------------

@pytest.mark.parametrize("role, script, message", [
    ("actuator", b"write 0 " + b"01 " * 5000 + b"\nsync\nbogus\n",
     "3:1: bad script line 'bogus' (write REG B..., sync [N], read REG N)"),
    ("actuator", b"sync 1_0\n", "1:1: sync count '1_0' is not a decimal number from 0 to 1000000"),
    ("actuator", b"write 0 1FF\n", "1:1: byte '1FF' is not a hex number from 0 to FF"),
    ("actuator", b"# \x0b\n", r"1:3: control character 0x0B (in an rx text write it as \x0B)"),
    ("sensor", b"adc 8 100\n", "1:1: adc channel '8' is not a decimal number from 0 to 7"),
    ("sensor", b"step\r\n# caf\xe9\n", "2:6: not UTF-8 text (byte 0xE9)"),
    ("sensor", b"fault adc maybe\n",
     "1:1: bad script line 'fault' (adc CH V, fault adc on|off, step [N], read REG N)"),
])
def test_peer_scripts_bad_lines(boards, tmp_path, role, script, message):
    """Lines of any length (a 15 kB write line is one line), control characters, UTF-8
    and numbers as on the central board; under ASan/UBSan, stderr is only the error."""
    path = tmp_path / "s.txt"
    path.write_bytes(script)
    proc = subprocess.run([str(boards / role / "firmware_host"), str(path)],
                          capture_output=True, timeout=60)
    assert proc.returncode == 1
    assert proc.stderr.decode() == f"error: {path}:{message}\n"
