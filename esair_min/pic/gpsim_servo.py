"""The actuator board's PIC firmware alone in gpsim: commanded angles -> servo pulses.

gpsim simulates one processor at a time, so the central firmware cannot drive the
actuator. :func:`measure_pulses` writes the register map straight into the firmware's
RAM (``reg(ADDR) = V`` at the address gplink gives the port's ``regs`` array), exactly
the bytes a frame write would leave there; then the sync line (RB0 through a pull-up whose voltage the
script drops to 0 V) falls, the
firmware latches, and ``FileRecorder`` modules record every servo pin. Pulse widths
are measured on the recordings and compared with ``pulse_min + (pulse_max -
pulse_min) * angle / 180``. The recorders, sync line and pulse measurement are shared
with the real I2C master of :mod:`esair_min.pic.gpsim_i2c` (tests/min/test_gpsim_slaves.py).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from esair_min.pic.gpsim_harness import _gpsim_pin
from esair_min.pic.gpsim_wave import read_edges
from esair_min.model.board import Servo
from esair_min.model.encoding import encode_pair
from esair_min.model.robot import Robot
from esair_min.pic.toolchain import Toolchain, ToolchainError, run_gpsim

SETTLE_CYCLES = 150_000       # 30 ms at 5 MIPS: start-up and a first PWM frame
RECORD_CYCLES = 300_000       # 60 ms after the latch: three 20 ms frames


@dataclass(frozen=True)
class ServoPulse:
    index: int
    angle: int
    expected_us: float
    measured_us: float
    period_us: float          # between the last two rising edges

    @property
    def error(self) -> float:
        return (self.measured_us - self.expected_us) / self.expected_us


def regs_address(map_text: str) -> int:
    """Data address of the actuator port's register map (``_regs`` in the map)."""
    m = re.search(r"^\s*_regs\s+0x([0-9a-fA-F]+)\s+data\b", map_text, re.M)
    if m is None:
        raise ToolchainError("no _regs array in the actuator firmware's map")
    return int(m.group(1), 16)


def expected_us(servo: Servo, angle: int) -> float:
    """The pulse width for ``angle``, clamped to the servo's limits as the firmware
    clamps it: ``pulse_min + (pulse_max - pulse_min) * angle / 180``."""
    angle = min(max(angle, servo.min_angle), servo.max_angle)
    return servo.pulse_min_us + (servo.pulse_max_us - servo.pulse_min_us) * angle / 180


def recorder_lines(robot: Robot) -> list[str]:
    """gpsim commands: the sync line on a pull-up ``PSY`` (high; ``PSY.voltage =
    0.0`` drops it) and a FileRecorder ``FR<i>`` writing ``servo<i>.txt`` on each servo pin."""
    act = robot.actuator
    if act is None or act.sync is None:
        raise ToolchainError("the robot has no actuator board with a sync pin")
    lines = ["module load pullup PSY", "node nsync",
             f"attach nsync {_gpsim_pin(act.sync.pin)} PSY.pin"]
    for s in robot.servos:
        lines += [f"module load FileRecorder FR{s.index}", f"FR{s.index}.digital = true",
                  f'FR{s.index}.file = "servo{s.index}.txt"', f"node ns{s.index}",
                  f"attach ns{s.index} {_gpsim_pin(s.pin)} FR{s.index}.pin"]
    return lines


def flush_lines(robot: Robot, then: str | None = None) -> list[str]:
    """gpsim commands that close the recordings (run them before reading them); with
    ``then``, recording goes on in ``<then><i>.txt``."""
    return [f'FR{s.index}.file = "{"/dev/null" if then is None else f"{then}{s.index}.txt"}"'
            for s in robot.servos]


def read_pulses(robot: Robot, angles: list[int], workdir: Path, after: int,
                record_cycles: int = RECORD_CYCLES) -> list[ServoPulse]:
    """Each servo's last complete pulse and last period in the recordings, edges after
    cycle ``after`` only, against ``angles`` (clamped to the limits)."""
    act = robot.actuator
    if act is None:
        raise ToolchainError("the robot has no actuator board")
    cps = act.mcu.clock_hz // 4
    result = []
    for s, angle in zip(robot.servos, angles):
        edges = [(c, v) for c, v in read_edges(Path(workdir) / f"servo{s.index}.txt")
                 if c > after]
        widths = [b[0] - a[0] for a, b in zip(edges, edges[1:]) if a[1] == 1 and b[1] == 0]
        rises = [c for c, v in edges if v == 1]
        if not widths or len(rises) < 2:
            raise ToolchainError(f"servo {s.index} ({s.pin}): no complete pulse in the "
                                 f"{record_cycles * 1000 // cps} ms after the latch")
        result.append(ServoPulse(s.index, angle, expected_us(s, angle),
                                 widths[-1] * 1e6 / cps, (rises[-1] - rises[-2]) * 1e6 / cps))
    return result


def measure_pulses(robot: Robot, angles: list[int], cod: Path, map_path: Path,
                   workdir: Path, tc: Toolchain | None = None) -> list[ServoPulse]:
    """Latch ``angles`` (speed 0: at once) into the actuator firmware; measure each
    servo's last complete pulse and its last period."""
    act = robot.actuator
    if act is None:
        raise ToolchainError("the robot has no actuator board")
    servos = robot.servos
    if len(angles) != len(servos):
        raise ToolchainError(f"{len(angles)} angles for {len(servos)} servos")
    base = regs_address(Path(map_path).read_text(errors="replace"))
    L = [f"load {Path(cod).resolve()}", "p18f452.BreakOnInvalidRegisterWrite = false",
         f"frequency {act.mcu.clock_hz}", "module library libgpsim_modules.so.0",
         *recorder_lines(robot), f"break c {SETTLE_CYCLES}", "run"]
    for s, angle in zip(servos, angles):
        low, high = encode_pair(angle, 0)
        L += [f"reg({base + 2 * s.index:#x}) = {low:#04x}",
              f"reg({base + 2 * s.index + 1:#x}) = {high:#04x}"]
    L += ["PSY.voltage = 0.0", f"break c {SETTLE_CYCLES + RECORD_CYCLES}", "run",
          *flush_lines(robot), "quit"]
    out = run_gpsim("\n".join(L) + "\n", workdir, tc=tc, script_name="servo.stc")
    if "***ERROR" in out:
        raise ToolchainError("gpsim rejected a command:\n" + out[-1500:])
    return read_pulses(robot, angles, workdir, SETTLE_CYCLES)
