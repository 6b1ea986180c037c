"""``esair emulate`` for a robot with an omni base (STARFISH): the boards and the room
(:class:`~esair_min.emulator.starfish.robot_sim.StarfishSim`) served on a pty, or run headless."""

from __future__ import annotations

import secrets
from collections.abc import Callable
from contextlib import ExitStack
from typing import Any, TextIO

from esair_min.emulator.starfish.robot_sim import StarfishSim
from esair_min.emulator.starfish.pose_trace import write_header, write_rows
from esair_min.errors import EsairError
from esair_min.model.robot import Robot
from esair_min.world import Pose, Room, World, load_room

#: A headless run advances in steps of this much virtual time, printing as it goes.
RUN_STEP_S = 0.05


def _refuse(opts: Any) -> None:
    for flag, used in (("--scenario", opts.scenario is not None),
                       ("the fault options", opts.faults.describe() != "none")):
        if used:
            raise EsairError(f"{flag}: not for a robot with an omni base (STARFISH), whose "
                             "sensors and faults are its room's (docs/emulator.md)")
    if opts.world_out is not None and not opts.pty:
        raise EsairError("--world-out works with --pty only")


def make_sim(robot: Robot, room_path: Any = None, pose: tuple[float, float, float] | None = None,
             robot_id: str | None = None) -> StarfishSim:
    """The robot in its room, at ``pose`` (mm, mm, rad) or the room's centre facing +x."""
    room = load_room(room_path) if room_path is not None else Room.default()
    if pose is None:
        x0, y0, x1, y1 = room.bounds()
        pose = ((x0 + x1) / 2, (y0 + y1) / 2, 0.0)
    world = World(room=room, pose=Pose(*pose))
    radius = world.options.radius_mm
    if room.clearance(pose[0], pose[1]) < radius:
        raise EsairError(f"--pose {pose[0]:g},{pose[1]:g}: the robot (radius {radius:g} mm) "
                         "would stand in a wall")
    return StarfishSim(robot, world, robot_id=robot_id)


def emulate_starfish(robot: Robot, opts: Any, out: TextIO, log: Callable[[str], None],
                     _serve_loop: Any, printer: Any) -> int:
    _refuse(opts)
    if opts.generate is not None:
        from esair_min.codegen import generate_robot

        generate_robot(robot, opts.generate)
        log(f"generated {robot.name} into {opts.generate}")
    robot_id = opts.instance
    if robot_id is None and opts.pty:           # each boot on a pty is a robot of its own
        robot_id = secrets.token_hex(4)
    sim = make_sim(robot, opts.room, opts.pose, robot_id)
    with ExitStack() as stack:
        flush: Callable[[], None] = lambda: None    # noqa: E731
        if opts.trace is not None:
            try:
                f = stack.enter_context(open(opts.trace, "w", encoding="ascii",
                                             buffering=1 if opts.pty else -1))
            except OSError as exc:
                raise EsairError(f"cannot write the trace {opts.trace}: {exc.strerror}") from None
            write_header(f, sim.world.room)

            def flush() -> None:
                write_rows(f, sim.trace)
                sim.trace.clear()
        else:
            sim.keep_trace = False
        stop = _serve_loop()
        stop.install()
        try:
            if opts.pty:
                from esair_min.emulator.ptyserver import serve_pty

                def on_path(path: str) -> None:
                    out.write(path + "\n")
                    out.flush()

                from esair_min.emulator.ptyserver import PtyPort

                port = PtyPort()
                live = out.isatty() if opts.live is None else opts.live
                view = None

                world_out = None
                if opts.world_out is not None:
                    from esair_min.emulator.world_out import WorldPublisher

                    world_out = WorldPublisher(opts.world_out)
                    stack.callback(world_out.close)
                published = -1

                def on_idle() -> None:
                    nonlocal view, published
                    flush()
                    if world_out is not None and sim.core.polls != published:
                        published = sim.core.polls      # once per central tick
                        p = sim.world.pose
                        world_out.publish(sim.now_s, p.x, p.y, p.theta, sim.world.collisions)
                    if not live:
                        return
                    if view is None:          # after the path is printed, as PAPA-MAN's
                        from esair_min.emulator.starfish.view import StarfishView

                        view = stack.enter_context(StarfishView(sim, port, out=out))
                    view.poll()

                serve_pty(sim, on_path, lambda: stop.flag, opts.speed or 1.0,  # type: ignore[arg-type]
                          on_idle, port)
                return 0
            sim.settle()
            if opts.sends:
                sim.write(b"".join(s.encode("latin-1") + b"\r\n" for s in opts.sends))
            end = opts.run_s
            show = printer(out)
            while not stop.flag and sim.now_s < end:
                show(sim.read())
                sim.run_until(round(min(end, sim.now_s + RUN_STEP_S) * 1e9))
                flush()
            show(sim.read(), last=True)
            flush()
        finally:
            stop.restore()
        p = sim.world.pose
        log(f"pose after {sim.now_s:g} s: x {p.x:.1f} mm, y {p.y:.1f} mm, theta "
            f"{p.theta:.4f} rad; wall contacts {sim.world.collisions}; drive writes "
            f"{sim.i2c_writes} ({sim.i2c_dropped} dropped from the record of the last "
            f"{sim.i2c_keep})")
        return 130 if stop.flag else 0
