"""STARFISH's part of ``esair emulate`` (:class:`~esair_min.emulator.serve.RobotRun`): the
boards and the room (:class:`~esair_min.emulator.starfish.robot_sim.StarfishSim`), the
pose trace, the true pose on a side channel (``--world-out``) and the room's live view."""

from __future__ import annotations

from contextlib import ExitStack
from typing import Any, TextIO

from esair_min.emulator.starfish.pose_trace import write_header, write_rows
from esair_min.emulator.starfish.robot_sim import StarfishSim
from esair_min.errors import EsairError
from esair_min.model.robot import Robot
from esair_min.world import Pose, Room, World, load_room


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


class StarfishRun:
    """The emulated boards of a robot with an omni base (STARFISH), in its room."""

    run_from_boot = True

    @staticmethod
    def refuse(opts: Any) -> None:
        """Options of PAPA-MAN's boards, and ``--world-out`` without a pty."""
        for flag, used in (("--scenario", opts.scenario is not None),
                           ("the fault options", opts.faults.describe() != "none")):
            if used:
                raise EsairError(f"{flag}: not for a robot with an omni base (STARFISH), whose "
                                 "sensors and faults are its room's (docs/emulator.md)")
        if opts.world_out is not None and not opts.pty:
            raise EsairError("--world-out works with --pty only")

    def __init__(self, robot: Robot, opts: Any, stack: ExitStack, image: bytes | None,
                 trace: TextIO | None, instance: str | None, live: bool):
        self.sim = sim = make_sim(robot, opts.room, opts.pose, instance)
        self._trace = trace
        if trace is not None:
            write_header(trace, sim.world.room)
        else:
            sim.keep_trace = False
        self._world_out = None
        if opts.world_out is not None:
            from esair_min.emulator.world_out import WorldPublisher

            self._world_out = WorldPublisher(opts.world_out)
            stack.callback(self._world_out.close)
        self._published = -1

    def install(self) -> None:
        """No signal of its own."""

    def restore(self) -> None:
        """Nothing to put back."""

    def flush(self) -> None:
        if self._trace is not None:
            write_rows(self._trace, self.sim.trace)
            self.sim.trace.clear()

    def idle(self) -> None:
        sim = self.sim
        self.flush()
        if self._world_out is not None and sim.core.polls != self._published:
            self._published = sim.core.polls      # once per central tick
            p = sim.world.pose
            self._world_out.publish(sim.now_s, p.x, p.y, p.theta, sim.world.collisions)

    def view(self, port: Any, out: TextIO) -> Any:
        from esair_min.emulator.starfish.view import StarfishView

        return StarfishView(self.sim, port, out=out)

    def closing(self) -> str | None:
        sim = self.sim
        p = sim.world.pose
        return (f"pose after {sim.now_s:g} s: x {p.x:.1f} mm, y {p.y:.1f} mm, theta "
                f"{p.theta:.4f} rad; wall contacts {sim.world.collisions}; drive writes "
                f"{sim.i2c_writes} ({sim.i2c_dropped} dropped from the record of the last "
                f"{sim.i2c_keep})")
