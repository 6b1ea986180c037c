"""STARFISH emulated in Python: the central board's core, the drive board, the two
flow sensors and the robot's body in a 2-D room (:mod:`esair_min.world`), on one
virtual clock.

Events: the central board's tick (its Timer2 period: flow polls, watchdog) and the drive
board's control tick (:data:`~esair_min.components.dc_motor.core.CONTROL_TICK_MS`:
ramps and duties). The world steps once per central tick (and at the end of a run),
with each wheel's mean rim speed since its last step, through the omni kinematics; each
flow sensor then sees the floor move under it.
A command line is decoded when it is given (the UART's byte time is not modelled here).
The trace keeps, per central tick, the virtual time, the true pose and the wheels' rim
speeds; ``i2c`` keeps every write to the drive board.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from esair_min.components.dc_motor.core import CONTROL_TICK_MS, DriveCore
from esair_min.components.omni_base.core import StarfishCore
from esair_min.components.omni_base.kinematics import inverse
from esair_min.components.optical_flow.core import Adns2610
from esair_min.world import World


#: What the central board sends at reset.
READY_LINE = b"!READY esair-min/1 starfish\r\n"


@dataclass(frozen=True)
class TraceRow:
    t_s: float
    x: float
    y: float
    theta: float
    wheels: tuple[float, ...]
    collided: bool


@dataclass
class FlowOptions:
    """The floor as the flow sensors see it."""

    noise: float = 0.02        # standard deviation of the counts, fraction of the motion
    surface: int = 90          # SQUAL
    seed: int = 1


@dataclass
class StarfishSim:
    robot: Any
    world: World = field(default_factory=World)
    flow_options: FlowOptions = field(default_factory=FlowOptions)
    keep_trace: bool = True
    robot_id: str | None = None        # the v reply's id= (an emulator's boot)

    def __post_init__(self) -> None:
        central = self.robot.central
        self.drive = DriveCore(self.robot.board("drive"))
        fo = self.flow_options
        self.sensors = [Adns2610(cpi=f.cpi, surface=fo.surface, noise=fo.noise, seed=fo.seed + i)
                        for i, f in enumerate(central.flow_sensors)]
        self.mounts = [(float(f.mount_x_mm), float(f.mount_y_mm), math.radians(f.mount_angle_deg))
                       for f in central.flow_sensors]
        self.i2c: list[tuple[int, int, bytes]] = []      # (t_ns, address, data)
        self.core = StarfishCore(self.robot, self._write, self.sensors, self.robot_id)
        self.t_ns = 0
        self._next_central = self.core.tick_ns
        self._drive_ns = CONTROL_TICK_MS * 1_000_000
        self._next_drive = self._drive_ns
        self.notices = bytearray()
        self.trace: list[TraceRow] = []
        self._inv = inverse(self.core.wheels)
        self._frames = [(px, py, math.cos(phi), math.sin(phi)) for px, py, phi in self.mounts]
        self._acc_dt = 0.0
        self._acc_travel = [0.0] * len(self.core.wheels)
        self._out = bytearray()
        self._booted = False
        self._collided = False

    def _write(self, address: int, data: bytes) -> bool:
        self.i2c.append((self.t_ns, address, bytes(data)))
        if address != self.drive.address or not data:
            return False
        self.drive.write(data[0], data[1:])
        return True

    # -- the link ------------------------------------------------------------------------
    def send(self, line: str | bytes) -> bytes:
        """A command line (terminator added): the reply bytes."""
        raw = line.encode() if isinstance(line, str) else bytes(line)
        return self.core.feed(raw + b"\r\n")

    def command(self, line: str | bytes) -> str:
        return self.send(line).decode().strip()

    # -- time ----------------------------------------------------------------------------
    def _advance(self, dt_s: float) -> None:
        """Time passes with the wheels as they are: their travel is kept until the next
        move (the drive board's ticks fall between the central board's; one world step
        per central tick, with each wheel's mean rim speed since the last)."""
        self._acc_dt += dt_s
        rims = self.drive.rims
        if any(rims):                      # (standing wheels add nothing)
            travel = self._acc_travel
            for k, v in enumerate(rims):
                travel[k] += v * dt_s

    def _move(self) -> None:
        dt_s = self._acc_dt
        if dt_s <= 0:
            return
        travel = self._acc_travel
        self._acc_dt = 0.0
        self._acc_travel = [0.0] * len(travel)
        (a, b, c), (d, e, f), (g, h, i) = self._inv     # body_velocity, inlined
        s0, s1, s2 = travel[0] / dt_s, travel[1] / dt_s, travel[2] / dt_s
        step = self.world.step(dt_s, a * s0 + b * s1 + c * s2, d * s0 + e * s1 + f * s2,
                               g * s0 + h * s1 + i * s2)
        if step.collided:
            self._collided = True
        svx, svy, omega = step.vx, step.vy, step.omega
        if svx == 0.0 and svy == 0.0 and omega == 0.0:
            return
        for sensor, (px, py, c, s) in zip(self.sensors, self._frames, strict=True):
            ux = (svx - omega * py) * dt_s
            uy = (svy + omega * px) * dt_s
            sensor.move(c * ux + s * uy, -s * ux + c * uy, dt_s)

    def run_until(self, t_ns: int) -> None:
        self._collided = False
        drive, core, tick_ns, drive_ns = self.drive, self.core, self.core.tick_ns, self._drive_ns
        next_central, next_drive = self._next_central, self._next_drive
        try:
            while True:
                nxt = next_central if next_central < next_drive else next_drive
                if nxt > t_ns:
                    break
                if nxt > self.t_ns:
                    self._advance((nxt - self.t_ns) / 1e9)
                    self.t_ns = nxt
                if nxt == next_drive:
                    drive.tick()
                    next_drive += drive_ns
                if nxt == next_central:
                    self._move()                     # the floor has moved under the sensors
                    notice = core.tick()
                    if notice:
                        self.notices += notice
                    next_central += tick_ns
                    if self.keep_trace:
                        p = self.world.pose
                        self.trace.append(TraceRow(self.t_ns / 1e9, p.x, p.y, p.theta,
                                                   drive.rims, self._collided))
        finally:
            self._next_central, self._next_drive = next_central, next_drive
        if t_ns > self.t_ns:
            self._advance((t_ns - self.t_ns) / 1e9)
            self.t_ns = t_ns
        self._move()

    def run_for(self, seconds: float) -> None:
        self.run_until(self.t_ns + round(seconds * 1e9))

    @property
    def now_s(self) -> float:
        return self.t_ns / 1e9

    # -- the serial side, as esair_min.emulator.ptyserver and Pacer drive an emulator ----
    @property
    def clock(self) -> StarfishSim:
        return self                       # ``clock.now``: the virtual time in ns

    @property
    def now(self) -> int:
        return self.t_ns

    def next_event_ns(self) -> int | None:
        return min(self._next_central, self._next_drive)

    def settle(self, max_s: float = 1.0) -> None:
        """Boot: the central board says it is ready (once)."""
        if not self._booted:
            self._booted = True
            self._out += READY_LINE

    def write(self, data: bytes) -> None:
        """Bytes from the host, decoded at the current virtual time."""
        self._out += self.core.feed(bytes(data))

    def read(self) -> bytes:
        """What the robot sent since the last read: replies and notices."""
        if self.notices:
            self._out += self.notices
            self.notices.clear()
        out = bytes(self._out)
        self._out.clear()
        return out

    def close(self) -> None:
        return None


@dataclass(frozen=True)
class SquareRun:
    """What :func:`drive_square` measured: the true pose and the flow odometry's pose at
    the end, the largest distance between them along the way, and the odometry polls."""

    true_end: tuple[float, float, float]
    odometry_end: tuple[float, float, float]
    max_error_mm: float
    polls: int
    refused: int

    @property
    def end_error_mm(self) -> float:
        return math.hypot(self.true_end[0] - self.odometry_end[0],
                          self.true_end[1] - self.odometry_end[1])


def drive_square(sim: StarfishSim, side_mm: float, speed_mm_s: int = 250,
                 period_s: float = 0.05, laps: int = 1) -> SquareRun:
    """A host driving a square (no turning: an omni base slides along each side): it
    sends the leg's velocity and asks for the odometry every ``period_s`` (so the
    watchdog stays fed), integrates the flow counts and compares with the world."""
    from esair_min.components.omni_base.core import velocity_line
    from esair_min.components.optical_flow.odometry import FlowOdometry, parse_odometry

    p = sim.world.pose
    odo = FlowOdometry(sim.robot.central.flow_sensors, p.x, p.y, p.theta)
    legs = [(speed_mm_s, 0), (0, speed_mm_s), (-speed_mm_s, 0), (0, -speed_mm_s)]
    worst, polls, refused = 0.0, 0, 0
    est = (p.x, p.y, p.theta)

    def poll() -> None:
        nonlocal worst, polls, est
        _, sensors = parse_odometry(sim.command("O"))
        est = odo.update([(dx, dy) for dx, dy, _ in sensors])
        polls += 1
        now = sim.world.pose
        worst = max(worst, math.hypot(est[0] - now.x, est[1] - now.y))

    poll()
    for _ in range(laps):
        for vx, vy in legs:
            for _ in range(round(side_mm / speed_mm_s / period_s)):
                if sim.command(velocity_line(vx, vy, 0)) != "OK":
                    refused += 1
                sim.run_for(period_s)
                poll()
    sim.command("x")
    sim.run_for(0.3)
    poll()
    end = sim.world.pose
    return SquareRun((end.x, end.y, end.theta), est, worst, polls, refused)
