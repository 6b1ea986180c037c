"""STARFISH's central ticks in runs: while the drive board is settled and nothing else
is due before the next tick, :func:`central_run` runs tick after tick in one call, on
locals, instead of one clock event and six method calls per tick.

The declared source of its arithmetic is the plain path, one tick per clock event
(``StarfishSim._timers_plain``): :meth:`World.advance` (``esair_min/world/body.py``),
:meth:`Adns2610.move` and :meth:`Adns2610.deltas` (``components/optical_flow/core.py``)
and :meth:`StarfishCore.tick`, with their constants imported from there (the burst's
timing, ``TWOPI``, ``REST``). Each fused tick does what the plain path does, in the same
order and with the same float operations, so the traces are identical; the check is
tests/min/test_fast_paths.py (``test_the_sims_fused_central_tick_is_the_plain_path``:
trace, bus, notices, poses, sums and generator states equal, with walls, noise, lag
and slip). The run's state lives in locals and is written back to the objects when it
ends: nothing can look at them in between, since no other event runs inside the run.

A run is not started (the plain path runs the tick) when the world has lag or slip, a
sensor's generator holds half a Gaussian pair, or a reader is not an
:class:`Adns2610`'s burst; it ends before a tick whose watchdog fires or whose sensor
reads would come too early (the plain path runs that tick: its notice, its write, its
error), and when the next tick is not the next thing to happen
(:meth:`VirtualClock.advance_inline`).

``sim`` is a :class:`~esair_min.emulator.starfish.robot_sim.StarfishSim` (typed ``Any``: that
module imports this one).
"""

from __future__ import annotations

import math
from typing import Any

from esair_min.components.optical_flow.core import (BURST_END_NS, BURST_FREE_NS, TWOPI,
                                                    MAX_SPEED_IPS, MM_PER_INCH, REG_SQUAL,
                                                    Adns2610)
from esair_min.emulator.starfish.pose_trace import TraceRow
from esair_min.world.body import REST, new_pose

_M32 = (1 << 32) - 1
_DELTAS = Adns2610.deltas
_cos, _sin, _hypot, _sqrt, _log = math.cos, math.sin, math.hypot, math.sqrt, math.log


def plan(sim: Any) -> list[tuple] | None:
    """What a run needs of each flow sensor that stays as it is (the sensor, its
    generator's ``random``, its sums, its mount frame), built once; None when the sim
    cannot run ticks in one call (three wheels, each reader an Adns2610's burst)."""
    if len(sim.drive.rims) != 3 or len(sim.sensors) != len(sim.core.sums):
        return None
    for s, read in zip(sim.sensors, sim.core._readers, strict=True):
        if (getattr(read, "__func__", None) is not _DELTAS
                or getattr(read, "__self__", None) is not s):
            return None
    return [(s, s._rng.random, sums, fx, fy, fc, fs)
            for s, sums, (fx, fy, fc, fs) in zip(sim.sensors, sim.core.sums, sim._frames,
                                                 strict=True)]


def central_run(sim: Any, now: int) -> None:
    """The central board's tick due ``now`` (the drive board settled) and the ticks after
    it while nothing else is due before them: :meth:`StarfishSim._central_settled` of
    each, in one call."""
    sensors = sim._run_plan
    world = sim.world
    opts = world.options
    if (sensors is None or now != sim._next_central or opts.lag_s > 0 or opts.slip
            or opts.slip_noise):
        sim._central_settled(now)
        return
    objs = sim.sensors
    for s in objs:
        if s.noise and s._rng.gauss_next is not None:
            sim._central_settled(now)                      # half a pair drawn: random.gauss
            return
    clock, core = sim.clock, sim.core
    advance_inline = clock.advance_inline
    # the wheels' travel (StarfishSim._account / _central_settled)
    rims = sim.drive.rims
    r0, r1, r2 = rims
    moving = r0 or r1 or r2
    a, b, c, d, e, f, g, h, i = sim._inv9
    nd, dstep = sim._next_drive, sim._drive_ns
    acc_t, acc_dt = sim._acc_t, sim._acc_dt
    t0, t1, t2 = sim._acc_travel
    nc = now
    # the world (World.advance's clear-of-walls path)
    pose = world.pose
    px, py, pth = pose.x, pose.y, pose.theta
    w_t, wv, touch = world.t_s, world._v, world._touching
    cx, cy = world._checked
    margin = world._margin
    moved = False
    # the central board (StarfishCore.tick)
    tick_ns, ct, polls = core.tick_ns, core.t_ns, core.polls
    idle, wticks, driving = core.idle_ticks, core.watchdog_ticks, any(core.commanded)
    trace = None
    if sim.keep_trace:
        trace = sim.trace
    collided = sim._collided
    ran = 0
    while True:
        nidle = idle + 1 if idle < 0xFFFF else idle
        if nidle >= wticks and driving:
            break                                    # the watchdog fires: the plain tick
        t = ct + tick_ns
        late = False
        for s in objs:                               # each burst read's timing check
            if t < s._free_at:
                late = True
                break
            t += BURST_END_NS
        if late:
            break                                    # the plain tick raises FlowTimingError
        # -- the wheels' travel since the last tick ------------------------------------
        while nd <= now:
            if nd > acc_t:
                dt_s = (nd - acc_t) / 1e9
                acc_dt += dt_s
                if moving:
                    t0 += r0 * dt_s
                    t1 += r1 * dt_s
                    t2 += r2 * dt_s
                acc_t = nd
            nd += dstep
        if now > acc_t:
            dt_s = (now - acc_t) / 1e9
            acc_dt += dt_s
            if moving:
                t0 += r0 * dt_s
                t1 += r1 * dt_s
                t2 += r2 * dt_s
            acc_t = now
        if acc_dt > 0:
            # -- the world's step --------------------------------------------------------
            s0, s1, s2 = t0 / acc_dt, t1 / acc_dt, t2 / acc_dt
            vx, vy, om = a * s0 + b * s1 + c * s2, d * s0 + e * s1 + f * s2, g * s0 + h * s1 + i * s2
            svx = svy = omega = 0.0
            if vx == 0 and vy == 0 and om == 0:     # at rest: only time passes
                wv = REST
                w_t += acc_dt
                moved = True
            else:
                mid = pth + om * acc_dt / 2
                cm, sm = _cos(mid), _sin(mid)
                x = px + (cm * vx - sm * vy) * acc_dt
                y = py + (sm * vx + cm * vy) * acc_dt
                if _hypot(x - cx, y - cy) < margin:
                    touch = False
                    px, py, pth = x, y, pth + om * acc_dt
                    wv = (vx, vy, om)
                    w_t += acc_dt
                    moved = True
                    svx, svy, omega = vx, vy, om
                else:                                # near a wall: through the world
                    if moved:
                        world.pose = new_pose(px, py, pth)
                        world.t_s, world._v, world._touching = w_t, wv, touch
                    svx, svy, omega, col = world.advance(acc_dt, vx, vy, om)
                    if col:
                        collided = True
                    pose = world.pose
                    px, py, pth = pose.x, pose.y, pose.theta
                    w_t, wv, touch = world.t_s, world._v, world._touching
                    cx, cy = world._checked
                    margin = world._margin
                    moved = False
            # -- the floor under the sensors (Adns2610.move) -------------------------------
            if svx != 0.0 or svy != 0.0 or omega != 0.0:
                for s, rnd, _, fx, fy, fc, fs in sensors:
                    ux = (svx - omega * fy) * acc_dt
                    uy = (svy + omega * fx) * acc_dt
                    dx_mm = fc * ux + fs * uy
                    dy_mm = -fs * ux + fc * uy
                    dist = _hypot(dx_mm, dy_mm)
                    if s.lifted or dist / MM_PER_INCH / acc_dt > MAX_SPEED_IPS:
                        if dist:
                            s.lost += 1
                        continue
                    k = s.cpi / MM_PER_INCH
                    acc = s._acc
                    noise = s.noise
                    if noise:
                        x2pi = rnd() * TWOPI
                        g2rad = _sqrt(-2.0 * _log(1.0 - rnd()))
                        acc[0] += (dx_mm + (0.0 + _cos(x2pi) * g2rad * (noise * abs(dx_mm)))) * k
                        acc[1] += (dy_mm + (0.0 + _sin(x2pi) * g2rad * (noise * abs(dy_mm)))) * k
                    else:
                        acc[0] += (dx_mm + 0.0) * k
                        acc[1] += (dy_mm + 0.0) * k
            acc_dt = 0.0
            t0 = t1 = t2 = 0.0
        # -- the central board's tick: the burst reads and the sums (Adns2610.deltas) ---
        ct += tick_ns
        t = ct
        for s, _, sums, _, _, _, _ in sensors:
            acc = s._acc
            ry = int(acc[1])                         # Delta_Y first, as the firmware reads
            if ry:
                ry = -128 if ry < -128 else 127 if ry > 127 else ry
                acc[1] -= ry
            rx = int(acc[0])
            if rx:
                rx = -128 if rx < -128 else 127 if rx > 127 else rx
                acc[0] -= rx
            s._free_at = t + BURST_FREE_NS
            sums[2] = 0 if s.lifted else s.surface
            if rx:
                sums[0] = (sums[0] + rx) & _M32
            if ry:
                sums[1] = (sums[1] + ry) & _M32
            t += BURST_END_NS
        polls += 1
        idle = nidle
        nc += tick_ns
        if trace is not None:
            trace.append(TraceRow(now / 1e9, px, py, pth, rims, collided))
        collided = False
        ran += 1
        if not advance_inline(nc):
            break
        now = nc
    # -- the run's state back into the objects -------------------------------------------
    sim._acc_t, sim._acc_dt, sim._acc_travel = acc_t, acc_dt, [t0, t1, t2]
    sim._next_drive = nd
    sim._next_central = nc
    sim._collided = collided
    if moved:
        world.pose = new_pose(px, py, pth)
        world.t_s, world._v, world._touching = w_t, wv, touch
    if ran:
        core.t_ns, core.polls, core.idle_ticks = ct, polls, idle
        for s in objs:
            s._reg = REG_SQUAL
            s._addr_at = None
    if nc == now:                                    # a tick the run left to the plain path
        sim._central_settled(now)
    else:
        sim._timer_at = nc
        clock.schedule(nc, sim._timers_cb)
