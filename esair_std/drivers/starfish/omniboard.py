"""What the Starfish driver and ``turn_and_shoot`` need of an omni-base robot's board
files, as plain data: MinLink's :class:`~..minlink.board.Board` (the line's baud, tick,
checksum setting), the flow sensors' mounts and top speed (the odometry), the drive
board's wheel count (the ``v`` reply's), its wheels' kinematics, limits and ramps (the
turn's profile, when a stop has them at rest) and the base's limits. Prepared where the
deployment is checked, so that the robot side never imports the board model
(pydantic); :func:`omni_of` also takes the model itself (a driver opened without that
preparation, a test), :func:`prepare_omni` reads the board files into it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping, NamedTuple

from ...transport.codec import JSONObject
from ..minlink.board import Board, board_of


class FlowMount(NamedTuple):
    """One flow sensor: its counts per inch and its place in the robot's frame."""

    cpi: int
    mount_x_mm: int
    mount_y_mm: int
    mount_angle_deg: int


class WheelMount(NamedTuple):
    """One wheel of the drive board: its top rim speed, distance from the centre and
    ramp (the board's speed change a second)."""

    limit_mm_s: float
    mount_radius_mm: float
    ramp_mm_s2: float


class OmniBoard:
    """One omni-base robot's link-relevant facts (see the module docstring)."""

    __slots__ = ("board", "flow", "wheels", "max_speed_mm_s", "max_omega_mrad_s", "drive",
                 "control_tick_s", "motors", "inverse", "flow_max_mm_s")

    def __init__(self, board: Board, flow: tuple[FlowMount, ...], wheels: int,
                 max_speed_mm_s: int, max_omega_mrad_s: int,
                 drive: tuple[tuple[float, float, float, float], ...] = (),
                 control_tick_s: float = 0.0, motors: tuple[WheelMount, ...] = (),
                 inverse: tuple[tuple[float, float, float], ...] = (),
                 flow_max_mm_s: float = 0.0):
        self.board, self.flow, self.wheels = board, flow, wheels
        self.max_speed_mm_s, self.max_omega_mrad_s = max_speed_mm_s, max_omega_mrad_s
        # each wheel's rim speed per vx, vy (mm/s) and omega (rad/s), and its ramp's step
        # a control tick (mm/s): when the wheels are at rest after a stop (omnilink.Wheels)
        self.drive, self.control_tick_s = drive, control_tick_s
        # the turn's limits (turn.py): each wheel's, the map from rim speeds back to
        # (vx, vy, omega), the speed beyond which a flow sensor loses counts
        self.motors, self.inverse, self.flow_max_mm_s = motors, inverse, flow_max_mm_s

    def to_json(self) -> JSONObject:
        return {"board": self.board.to_json(), "flow": [list(f) for f in self.flow],
                "wheels": self.wheels, "max_speed_mm_s": self.max_speed_mm_s,
                "max_omega_mrad_s": self.max_omega_mrad_s,
                "drive": [list(row) for row in self.drive], "control_tick_s": self.control_tick_s,
                "motors": [list(m) for m in self.motors],
                "inverse": [list(row) for row in self.inverse],
                "flow_max_mm_s": self.flow_max_mm_s}

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "OmniBoard":
        drive = tuple((float(a), float(b), float(c), float(e)) for a, b, c, e in d.get("drive", ()))
        motors = tuple(WheelMount(float(a), float(b), float(c)) for a, b, c in d.get("motors", ()))
        inverse = tuple((float(a), float(b), float(c)) for a, b, c in d.get("inverse", ()))
        return cls(Board.from_json(d["board"]), tuple(FlowMount(*f) for f in d["flow"]),
                   int(d["wheels"]), int(d["max_speed_mm_s"]), int(d["max_omega_mrad_s"]),
                   drive, float(d.get("control_tick_s", 0.0)), motors, inverse,
                   float(d.get("flow_max_mm_s", 0.0)))

    @property
    def has_turn(self) -> bool:
        """Whether it holds the turn's limits (an entry prepared before they were added
        holds the driver's only)."""
        return bool(self.motors) and len(self.inverse) == 3 and self.flow_max_mm_s > 0


def omni_of(robot: Any) -> OmniBoard:
    """The plain facts of esair_min's validated ``Robot`` with an omni base (already
    plain: itself)."""
    if isinstance(robot, OmniBoard):
        return robot
    central = robot.central
    base, drive = central.base, robot.board("drive")
    assert base is not None and drive is not None   # an omni base has both (validate.py)
    from esair_min.components.dc_motor.core import CONTROL_TICK_MS
    from esair_min.components.omni_base.kinematics import inverse, matrix, wheel_table
    from esair_min.components.optical_flow.core import MAX_SPEED_IPS, MM_PER_INCH
    tick = CONTROL_TICK_MS / 1000
    wheels = wheel_table(list(drive.motors))
    rows = matrix(wheels)
    inv = inverse(wheels) if len(wheels) == 3 else []
    return OmniBoard(board_of(robot),
                     tuple(FlowMount(int(f.cpi), int(f.mount_x_mm), int(f.mount_y_mm),
                                     int(f.mount_angle_deg)) for f in central.flow_sensors),
                     len(drive.motors), int(base.max_speed_mm_s), int(base.max_omega_mrad_s),
                     tuple((float(r[0]), float(r[1]), float(r[2]), m.ramp_mm_s2 * tick)
                           for r, m in zip(rows, drive.motors)), tick,
                     tuple(WheelMount(float(m.limit_mm_s), float(m.mount_radius_mm),
                                      float(m.ramp_mm_s2)) for m in drive.motors),
                     tuple((float(r[0]), float(r[1]), float(r[2])) for r in inv),
                     MAX_SPEED_IPS * MM_PER_INCH)


def prepare_omni(robot_arg: str, base: Path) -> tuple[OmniBoard, Path, list[str]]:
    """The robot ``robot_arg`` (a bundled robot's name, or its board files' folder or
    robot file, relative to ``base``) read and checked into an :class:`OmniBoard`, with
    its robot file and the files it was made from (the board files, and the modules that
    make it). Imports the board model (pydantic): where the deployment is checked. Raises
    ValueError naming the robot for a robot that is missing, bad, or has no omni base."""
    from esair_min.errors import EsairError
    from esair_min.model.validate import board_files, load_robot   # pydantic
    from esair_min.resources import resolve_robot
    from ..minlink.driver import in_folder
    try:
        path = resolve_robot(in_folder(base, robot_arg, must_exist=True))
        robot = load_robot(path)
    except EsairError as exc:
        raise ValueError(f"robot {robot_arg!r}: {exc}") from None
    if robot.central.base is None or robot.board("drive") is None:
        raise ValueError(f"robot {robot_arg!r} has no omni base (its central board has no "
                         "'base:', or it has no drive board)")
    return omni_of(robot), Path(path), [str(f) for f in board_files(path)] + [__file__]
