"""STARFISH emulated in Python: the central board's core, the drive board, the two
flow sensors and the robot's body in a 2-D room (:mod:`esair_min.world`), on one
virtual clock.

Events (a :class:`~esair_min.emulator.clock.VirtualClock`): the central board's tick
(its Timer2 period: flow polls, watchdog), the drive board's control tick
(:data:`~esair_min.components.dc_motor.core.CONTROL_TICK_MS`: ramps and duties), and
the bytes on the serial line. The world steps once per central tick (and at the end of
a run), with each wheel's mean rim speed since its last step, through the omni
kinematics; each flow sensor then sees the floor move under it.

The serial line is PAPA-MAN's (:mod:`..uart`, :mod:`..line`): bytes travel at the central
board's declared baud, into the 64-byte receive ring, and a line is decoded when its
last byte has arrived; a reply leaves through the 80-byte transmit ring at the same
pace, and while it has no room there the board waits (bytes arriving meanwhile wait in
the receive ring, or are lost to an overrun and the line answered ``E12``).
The trace keeps, per central tick, the virtual time, the true pose and the wheels' rim
speeds; ``i2c`` keeps the latest ``i2c_keep`` writes to the drive board (``i2c_writes``
counts them all, ``i2c_dropped`` the ones no longer kept: the live view and a headless
run's last line show both).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from typing import Any

from esair_min.components.dc_motor.core import CONTROL_TICK_MS, DriveCore
from esair_min.components.omni_base.core import StarfishCore, ready_line
from esair_min.components.omni_base.kinematics import inverse
from esair_min.components.optical_flow.core import Adns2610
from esair_min.emulator.clock import VirtualClock
from esair_min.emulator.line import SerialHost
from esair_min.emulator.starfish.fused_run import central_run, plan
from esair_min.emulator.starfish.pose_trace import TraceRow
from esair_min.emulator.uart import GAP, RX_BYTE, RX_HOLD, RX_TAKE, Uart
from esair_min.world import World


#: Drive-board writes a StarfishSim keeps (its ``i2c``): the latest, about 51 simulated
#: seconds of driving at 20 writes a second.
I2C_KEEP = 1024


@dataclass
class FlowOptions:
    """The floor as the flow sensors see it."""

    noise: float = 0.02        # standard deviation of the counts, fraction of the motion
    surface: int = 90          # SQUAL
    seed: int = 1


@dataclass
class StarfishSim(SerialHost):
    robot: Any
    world: World = field(default_factory=World)
    flow_options: FlowOptions = field(default_factory=FlowOptions)
    keep_trace: bool = True
    robot_id: str | None = None        # the v reply's id= (an emulator's boot)
    i2c_keep: int = I2C_KEEP           # drive-board writes kept in ``i2c`` (the latest)

    def __post_init__(self) -> None:
        central = self.robot.central
        self.drive = DriveCore(self.robot.board("drive"))
        fo = self.flow_options
        self.sensors = [Adns2610(cpi=f.cpi, surface=fo.surface, noise=fo.noise, seed=fo.seed + i)
                        for i, f in enumerate(central.flow_sensors)]
        self.mounts = [(float(f.mount_x_mm), float(f.mount_y_mm), math.radians(f.mount_angle_deg))
                       for f in central.flow_sensors]
        #: The latest writes to the drive board, (t_ns, address, data); i2c_writes counts all.
        self.i2c: deque[tuple[int, int, bytes]] = deque(maxlen=self.i2c_keep)
        self.i2c_writes = 0
        self.core = StarfishCore(self.robot, self._write, self.sensors, self.robot_id)
        self.clock = VirtualClock()
        self.uart = Uart(self.clock, central.uart.baud, self._feed, rx_mode=self._rx_mode,
                         direct=self._rx_run)
        self._busy_until = 0           # the superloop waits for transmit room until then
        self._feed_pending = False
        self._acc_t = 0                # wheel travel is accounted up to this time
        self._next_central = self.core.tick_ns
        self._drive_ns = CONTROL_TICK_MS * 1_000_000
        self._next_drive = self._drive_ns
        self._drive_live = True        # its ticks run as events (else: replayed, _replay)
        self._timer_at = -1            # when the pending _timers event is due
        self._timers_cb = self._timers  # (one bound method, not one per event)
        self._schedule_timers()
        #: Every notice the central board sent (the line carries them to the host too).
        self.notices = bytearray()
        self.trace: list[TraceRow] = []
        self._inv = inverse(self.core.wheels)
        self._inv9 = tuple(x for row in self._inv for x in row)
        self._frames = [(px, py, math.cos(phi), math.sin(phi)) for px, py, phi in self.mounts]
        self._acc_dt = 0.0
        self._acc_travel = [0.0] * len(self.core.wheels)
        self._collided = False
        self._run_plan = plan(self)    # (fused_run: ticks in runs)
        self._reply(ready_line(self.robot.name))   # at reset: the robot it is

    @property
    def i2c_dropped(self) -> int:
        """Writes to the drive board no longer kept in ``i2c`` (older than its latest
        ``i2c_keep``)."""
        return self.i2c_writes - len(self.i2c)

    def _write(self, address: int, data: bytes) -> bool:
        self.i2c.append((self.clock.now, address, bytes(data)))
        self.i2c_writes += 1
        if address != self.drive.address or not data:
            return False
        self._replay(self.clock.now)
        self.drive.write(data[0], data[1:])
        if not self._drive_live and not self.drive.settled:    # its ticks run as events again
            self._drive_live = True
            if self._next_drive < self._timer_at:
                self._schedule_timers()
        return True

    # -- the link ------------------------------------------------------------------------
    def send(self, line: str | bytes, timeout_s: float = 2.0) -> bytes:
        """A command line (terminator added) over the line: the reply's bytes once they
        have reached the host (b"" when none came within ``timeout_s``)."""
        got = self.exchange(line, timeout_s)
        return got[-1].encode("latin-1") + b"\r\n" if got and got[-1][:1] != "!" else b""

    def command(self, line: str | bytes, timeout_s: float = 2.0) -> str:
        """A command line over the line: its reply's text (notices skipped): what
        :meth:`send` gives, decoded and stripped."""
        got = self.exchange(line, timeout_s)
        return got[-1].strip() if got and got[-1][:1] != "!" else ""

    def _send_line(self, data: bytes, end_ns: int) -> None:
        """The host sends one line: on a quiet line (nothing on the wire either way or in
        the receive ring, the board not waiting) straight to the decoder when its CR has
        arrived, after every event due by then (the ticks), as the UART's run would
        take it (:meth:`Uart._rx_arrive`: a run of bytes while the board takes them,
        the line decoded at its CR, the LF after it swallowed); else onto the wire."""
        uart, clock = self.uart, self.clock
        now = clock.now
        n = len(data) + 2
        t_cr = now + (n - 1) * uart.byte_ns
        if (not data or 13 in data or 10 in data or t_cr >= end_ns or uart._rx_wire
                or uart._tx_wire or uart.ring or uart.overrun or self._busy_until > now
                or self._feed_pending):
            self.write(data + b"\r\n")
            return
        self._host_wrote(data + b"\r\n")
        uart._rx_free = t_cr + uart.byte_ns
        clock.run_until(t_cr)
        uart.rx_bytes += n
        self._reply(self.core.feed(data + b"\r\n"))

    @property
    def idle(self) -> bool:
        """No byte on the line either way, none waiting in the ring, not waiting for
        transmit room."""
        return self.uart.rx_idle and self.uart.tx_idle and self._busy_until <= self.clock.now

    # -- the central board's superloop ----------------------------------------------------
    def _reply(self, data: bytes) -> None:
        """The board sends ``data``: into the transmit ring, waiting for room."""
        if data:
            now = self.clock.now
            at = self._busy_until if self._busy_until > now else now
            self._busy_until = self.uart.board_send(data, at)

    def _rx_mode(self) -> int:
        """What the superloop would do with a byte arriving now (see :mod:`..uart`)."""
        if self._busy_until > self.clock.now:
            return RX_HOLD if self._feed_pending else RX_BYTE
        return RX_TAKE

    def _rx_run(self, data: bytes) -> None:
        """A run of bytes straight to the decoder (the UART's fast path)."""
        self._reply(self.core.feed(data))

    def _feed_event(self) -> None:
        self._feed_pending = False
        self._feed()

    def _feed(self) -> None:
        """The superloop: feed the decoder from the ring while it is not waiting."""
        ring, clock, core = self.uart.ring, self.clock, self.core
        while ring:
            if self._busy_until > clock.now:
                if not self._feed_pending:
                    self._feed_pending = True
                    clock.schedule(self._busy_until, self._feed_event)
                return
            b = ring.popleft()
            if b & GAP:                     # bytes were lost right before this one
                core.lines.note_overrun()
            self._reply(core.feed(bytes((b & 0xFF,))))

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
        svx, svy, omega, collided = self.world.advance(
            dt_s, a * s0 + b * s1 + c * s2, d * s0 + e * s1 + f * s2, g * s0 + h * s1 + i * s2)
        if collided:
            self._collided = True
        if svx == 0.0 and svy == 0.0 and omega == 0.0:
            return
        for sensor, (px, py, c, s) in zip(self.sensors, self._frames, strict=True):
            ux = (svx - omega * py) * dt_s
            uy = (svy + omega * px) * dt_s
            sensor.move(c * ux + s * uy, -s * ux + c * uy, dt_s)

    def _replay(self, t_ns: int) -> None:
        """The drive board's ticks due by ``t_ns`` while it is settled: not run as events
        (a settled board's tick changes nothing), but each still ends a stretch of the
        wheels' travel where it would have (the same sums as running each)."""
        if self._drive_live:
            return
        nd = self._next_drive
        while nd <= t_ns:
            if nd > self._acc_t:
                self._advance((nd - self._acc_t) / 1e9)
                self._acc_t = nd
            nd += self._drive_ns
        self._next_drive = nd

    def _account_plain(self, t_ns: int) -> None:
        self._replay(t_ns)
        if t_ns > self._acc_t:
            self._advance((t_ns - self._acc_t) / 1e9)
            self._acc_t = t_ns

    def _account(self, t_ns: int) -> None:
        """:meth:`_account_plain` (:meth:`_replay`, then :meth:`_advance` to ``t_ns``),
        inlined: the same sums."""
        acc_t = self._acc_t
        if t_ns <= acc_t and (self._drive_live or self._next_drive > t_ns):
            return
        rims = self.drive.rims
        moving = any(rims)                 # (standing wheels add nothing)
        travel = self._acc_travel
        acc_dt = self._acc_dt
        if not self._drive_live:
            nd, step = self._next_drive, self._drive_ns
            while nd <= t_ns:
                if nd > acc_t:
                    dt_s = (nd - acc_t) / 1e9
                    acc_dt += dt_s
                    if moving:
                        for k, v in enumerate(rims):
                            travel[k] += v * dt_s
                    acc_t = nd
                nd += step
            self._next_drive = nd
        if t_ns > acc_t:
            dt_s = (t_ns - acc_t) / 1e9
            acc_dt += dt_s
            if moving:
                for k, v in enumerate(rims):
                    travel[k] += v * dt_s
            acc_t = t_ns
        self._acc_t = acc_t
        self._acc_dt = acc_dt

    def _schedule_timers(self) -> None:
        nc, nd = self._next_central, self._next_drive
        self._timer_at = nd if self._drive_live and nd < nc else nc
        self.clock.schedule(self._timer_at, self._timers_cb)

    def _timers(self) -> None:
        """The boards' ticks due now (the drive board's first when both are)."""
        now = self.clock.now
        if now != self._timer_at:
            return                               # superseded: the drive board woke up
        if not self._drive_live:
            central_run(self, now)               # this tick and the next ones, in one call
            return
        self._timers_plain(now)

    def _central_settled(self, now: int) -> None:
        """:meth:`_timers_plain` when the drive board is settled (its ticks replayed, so
        this is the central board's tick), in one method: the wheels' travel since the
        last tick (:meth:`_account`, three wheels), the world's step and the sensors'
        motion (:meth:`_move`); the same floats in the same order."""
        acc_t, acc_dt = self._acc_t, self._acc_dt
        r0, r1, r2 = self.drive.rims
        moving = r0 or r1 or r2
        t0, t1, t2 = self._acc_travel
        nd, step = self._next_drive, self._drive_ns
        while nd <= now:
            if nd > acc_t:
                dt_s = (nd - acc_t) / 1e9
                acc_dt += dt_s
                if moving:
                    t0 += r0 * dt_s
                    t1 += r1 * dt_s
                    t2 += r2 * dt_s
                acc_t = nd
            nd += step
        self._next_drive = nd
        if now > acc_t:
            dt_s = (now - acc_t) / 1e9
            acc_dt += dt_s
            if moving:
                t0 += r0 * dt_s
                t1 += r1 * dt_s
                t2 += r2 * dt_s
            acc_t = now
        self._acc_t = acc_t
        if acc_dt > 0:                           # _move
            self._acc_dt = 0.0
            self._acc_travel = [0.0, 0.0, 0.0]
            a, b, c, d, e, f, g, h, i = self._inv9
            s0, s1, s2 = t0 / acc_dt, t1 / acc_dt, t2 / acc_dt
            svx, svy, omega, collided = self.world.advance(
                acc_dt, a * s0 + b * s1 + c * s2, d * s0 + e * s1 + f * s2,
                g * s0 + h * s1 + i * s2)
            if collided:
                self._collided = True
            if svx != 0.0 or svy != 0.0 or omega != 0.0:
                for sensor, (px, py, c, s) in zip(self.sensors, self._frames):
                    ux = (svx - omega * py) * acc_dt
                    uy = (svy + omega * px) * acc_dt
                    sensor.move(c * ux + s * uy, -s * ux + c * uy, acc_dt)
        else:
            self._acc_dt = acc_dt
        notice = self.core.tick()
        if notice:
            self.notices += notice
            self._reply(notice)
        nc = self._next_central = self._next_central + self.core.tick_ns
        if self.keep_trace:
            p = self.world.pose
            self.trace.append(TraceRow(now / 1e9, p.x, p.y, p.theta, self.drive.rims,
                                       self._collided))
        self._collided = False
        if self._drive_live:                     # the tick wrote to it (the watchdog stop)
            self._schedule_timers()
        else:                                    # _schedule_timers: the drive board waits
            self._timer_at = nc
            self.clock.schedule(nc, self._timers_cb)

    def _timers_plain(self, now: int) -> None:
        self._account(now)
        if self._drive_live and now == self._next_drive:
            self.drive.tick()
            self._next_drive += self._drive_ns
            self._drive_live = not self.drive.settled
        if now == self._next_central:
            self._move()                         # the floor has moved under the sensors
            notice = self.core.tick()
            if notice:
                self.notices += notice
                self._reply(notice)
            self._next_central += self.core.tick_ns
            if self.keep_trace:
                p = self.world.pose
                self.trace.append(TraceRow(now / 1e9, p.x, p.y, p.theta, self.drive.rims,
                                           self._collided))
            self._collided = False               # a row says: a wall stopped it since the last
        self._schedule_timers()

    def run_until(self, t_ns: int) -> None:
        """Run to ``t_ns``; the world then stands where the robot is at that time."""
        self.clock.run_until(t_ns)
        self._account(t_ns)
        self._move()

    def run_for(self, seconds: float) -> None:
        self.run_until(self.clock.now + round(seconds * 1e9))

    @property
    def t_ns(self) -> int:
        return self.clock.now

    @property
    def now_s(self) -> float:
        return self.clock.now / 1e9

    @property
    def now(self) -> int:
        return self.clock.now

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
        now = sim.world.pose            # when the host asks (the reply takes ~10 ms)
        _, sensors = parse_odometry(sim.command("O"))
        est = odo.update([(dx, dy) for dx, dy, _ in sensors])
        polls += 1
        worst = max(worst, math.hypot(est[0] - now.x, est[1] - now.y))

    poll()
    t, step = sim.clock.now, round(period_s * 1e9)   # periods kept whatever the line takes
    for _ in range(laps):
        for vx, vy in legs:
            for _ in range(round(side_mm / speed_mm_s / period_s)):
                if sim.command(velocity_line(vx, vy, 0)) != "OK":
                    refused += 1
                t += step
                sim.run_until(t)
                poll()
    sim.command("x")
    sim.run_until(t + 300_000_000)
    poll()
    end = sim.world.pose
    return SquareRun((end.x, end.y, end.theta), est, worst, polls, refused)
