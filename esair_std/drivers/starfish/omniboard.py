"""What the Starfish driver needs of an omni-base robot's board files, as plain data:
MinLink's :class:`~..minlink.board.Board` (the line's baud, tick, checksum setting),
the flow sensors' mounts (the odometry), the drive board's wheel count (the ``v``
reply's), its wheels' kinematics and ramps (when a stop has them at rest) and the
base's limits. Prepared where the deployment is checked, so that the
robot side never imports the board model (pydantic); :func:`omni_of` also takes the
model itself (a driver opened without that preparation, a test).
"""

from __future__ import annotations

from typing import Any, Mapping, NamedTuple

from ...transport.codec import JSONObject
from ..minlink.board import Board, board_of


class FlowMount(NamedTuple):
    """One flow sensor: its counts per inch and its place in the robot's frame."""

    cpi: int
    mount_x_mm: int
    mount_y_mm: int
    mount_angle_deg: int


class OmniBoard:
    """One omni-base robot's link-relevant facts (see the module docstring)."""

    __slots__ = ("board", "flow", "wheels", "max_speed_mm_s", "max_omega_mrad_s", "drive",
                 "control_tick_s")

    def __init__(self, board: Board, flow: tuple[FlowMount, ...], wheels: int,
                 max_speed_mm_s: int, max_omega_mrad_s: int,
                 drive: tuple[tuple[float, float, float, float], ...] = (),
                 control_tick_s: float = 0.0):
        self.board, self.flow, self.wheels = board, flow, wheels
        self.max_speed_mm_s, self.max_omega_mrad_s = max_speed_mm_s, max_omega_mrad_s
        # each wheel's rim speed per vx, vy (mm/s) and omega (rad/s), and its ramp's step
        # a control tick (mm/s): when the wheels are at rest after a stop (omnilink.Wheels)
        self.drive, self.control_tick_s = drive, control_tick_s

    def to_json(self) -> JSONObject:
        return {"board": self.board.to_json(), "flow": [list(f) for f in self.flow],
                "wheels": self.wheels, "max_speed_mm_s": self.max_speed_mm_s,
                "max_omega_mrad_s": self.max_omega_mrad_s,
                "drive": [list(row) for row in self.drive], "control_tick_s": self.control_tick_s}

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "OmniBoard":
        drive = tuple((float(a), float(b), float(c), float(e)) for a, b, c, e in d.get("drive", ()))
        return cls(Board.from_json(d["board"]), tuple(FlowMount(*f) for f in d["flow"]),
                   int(d["wheels"]), int(d["max_speed_mm_s"]), int(d["max_omega_mrad_s"]),
                   drive, float(d.get("control_tick_s", 0.0)))


def omni_of(robot: Any) -> OmniBoard:
    """The plain facts of esair_min's validated ``Robot`` with an omni base (already
    plain: itself)."""
    if isinstance(robot, OmniBoard):
        return robot
    central = robot.central
    base, drive = central.base, robot.board("drive")
    assert base is not None and drive is not None   # an omni base has both (validate.py)
    from esair_min.components.dc_motor.core import CONTROL_TICK_MS
    from esair_min.components.omni_base.kinematics import matrix, wheel_table
    tick = CONTROL_TICK_MS / 1000
    rows = matrix(wheel_table(list(drive.motors)))
    return OmniBoard(board_of(robot),
                     tuple(FlowMount(int(f.cpi), int(f.mount_x_mm), int(f.mount_y_mm),
                                     int(f.mount_angle_deg)) for f in central.flow_sensors),
                     len(drive.motors), int(base.max_speed_mm_s), int(base.max_omega_mrad_s),
                     tuple((float(r[0]), float(r[1]), float(r[2]), m.ramp_mm_s2 * tick)
                           for r, m in zip(rows, drive.motors)), tick)
