"""The actuator board's PIC firmware alone in gpsim: commanded angles -> servo pulses.

gpsim cannot act as I2C master to the actuator firmware (its ``i2cmaster`` module
never moves SCL/SDA, docs/toolchain.md), and it simulates one processor at a time, so
the central firmware cannot drive it either. Instead the register map is written
straight into the firmware's RAM (``reg(ADDR) = V`` at the address gplink gives the
port's ``regs`` array), exactly the bytes a frame write would leave there; then the
sync line (RB0 through a pull-up whose voltage the script drops to 0 V) falls, the
firmware latches, and ``FileRecorder`` modules record every servo pin. Pulse widths
are measured on the recordings and compared with ``pulse_min + (pulse_max -
pulse_min) * angle / 180``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from .gpsim_harness import _gpsim_pin
from .gpsim_wave import read_edges
from .robot import Robot
from .toolchain import Toolchain, ToolchainError, run_gpsim

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


def measure_pulses(robot: Robot, angles: list[int], cod: Path, map_path: Path,
                   workdir: Path, tc: Toolchain | None = None) -> list[ServoPulse]:
    """Latch ``angles`` (speed 0: at once) into the actuator firmware; measure each
    servo's last complete pulse and its last period."""
    act = robot.actuator
    if act is None or act.sync is None:
        raise ToolchainError("the robot has no actuator board with a sync pin")
    servos = robot.servos
    if len(angles) != len(servos):
        raise ToolchainError(f"{len(angles)} angles for {len(servos)} servos")
    base = regs_address(Path(map_path).read_text(errors="replace"))
    cps = act.mcu.clock_hz // 4
    L = [f"load {Path(cod).resolve()}", "p18f452.BreakOnInvalidRegisterWrite = false",
         f"frequency {act.mcu.clock_hz}", "module library libgpsim_modules.so.0",
         "module load pullup PSY", "node nsync",
         f"attach nsync {_gpsim_pin(act.sync.pin)} PSY.pin"]
    for s in servos:
        L += [f"module load FileRecorder FR{s.index}", f"FR{s.index}.digital = true",
              f'FR{s.index}.file = "servo{s.index}.txt"', f"node ns{s.index}",
              f"attach ns{s.index} {_gpsim_pin(s.pin)} FR{s.index}.pin"]
    L += [f"break c {SETTLE_CYCLES}", "run"]
    for s, angle in zip(servos, angles):
        L += [f"reg({base + 2 * s.index:#x}) = {angle % 100:#04x}",
              f"reg({base + 2 * s.index + 1:#x}) = {angle // 100:#04x}"]
    L += ["PSY.voltage = 0.0", f"break c {SETTLE_CYCLES + RECORD_CYCLES}", "run"]
    L += [f'FR{s.index}.file = "/dev/null"' for s in servos] + ["quit"]
    out = run_gpsim("\n".join(L) + "\n", workdir, tc=tc, script_name="servo.stc")
    if "***ERROR" in out:
        raise ToolchainError("gpsim rejected a command:\n" + out[-1500:])
    result = []
    for s, angle in zip(servos, angles):
        edges = [(c, v) for c, v in read_edges(workdir / f"servo{s.index}.txt")
                 if c > SETTLE_CYCLES]
        widths = [b[0] - a[0] for a, b in zip(edges, edges[1:]) if a[1] == 1 and b[1] == 0]
        rises = [c for c, v in edges if v == 1]
        if not widths or len(rises) < 2:
            raise ToolchainError(f"servo {s.index} ({s.pin}): no complete pulse in the "
                                 f"{RECORD_CYCLES * 1000 // cps} ms after the latch")
        expected = s.pulse_min_us + (s.pulse_max_us - s.pulse_min_us) * angle / 180
        result.append(ServoPulse(s.index, angle, expected, widths[-1] * 1e6 / cps,
                                 (rises[-1] - rises[-2]) * 1e6 / cps))
    return result
