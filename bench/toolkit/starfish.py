"""STARFISH's shot as every bench measures it: the example's deployment in its room, the
same source places, and each shot's floor from its own turn (issue 37 item 4)."""

from __future__ import annotations

import math
import time
from functools import cache
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
ROOM = ROOT / "esair_std" / "examples" / "starfish" / "room.yaml"
SOURCES = [(1.0, 3.5), (0.4, 0.4), (2.7, 3.7), (0.3, 2.0), (2.6, 0.3), (1.8, 3.7)]
PATROL = [[1.5, 1.5], [2.3, 1.5]]          # the segment the robot drives between shots


def deployment(store: str) -> dict:
    """The example deployment, driving ``PATROL`` in the example's room, its pictures kept
    in ``store``."""
    import yaml

    from esair_std.deploy import resolve_deployment

    dep = yaml.safe_load(Path(resolve_deployment("starfish")).read_text())
    dep["resources"]["starfish"].update(pose=[*PATROL[0], 0.0], room_file=str(ROOM))
    dep["reactions"]["reconnect"]["room_file"] = str(ROOM)
    dep["behaviors"]["patrol"]["waypoints"] = PATROL
    mod = "esair_std.examples.starfish.starfish_behaviors"
    for name in ("patrol", "localize", "turn_and_shoot"):
        dep["behaviors"][name]["class"] = f"{mod}:" + dep["behaviors"][name]["class"].split(":")[1]
    dep["reactions"]["reconnect"]["class"] = f"{mod}:Reconnect"
    dep["behaviors"]["turn_and_shoot"].update(store=store, cooldown=0.5)
    return dep


def camera_time(pose) -> float:
    """CPU seconds of one picture at ``pose`` (rendered and encoded, as the driver does),
    median of 3."""
    from esair_std.drivers.starfish.camera import Camera, encode
    from esair_std.drivers.starfish.scene import load_scene

    cam = Camera(load_scene(str(ROOM)))
    times = []
    for _ in range(3):
        t0 = time.process_time()
        encode(cam.render(pose), "png")
        times.append(time.process_time() - t0)
    return sorted(times)[1]


@cache
def turn_limits() -> tuple[float, float]:
    """(top turn rate rad/s, angular acceleration rad/s^2) from the board files."""
    from esair_min.model.validate import load_robot
    from esair_min.resources import resolve_robot
    from esair_std.drivers.starfish.turn import turn_limits as limits

    return limits(load_robot(resolve_robot("starfish")))


def shot_floor(last: dict, hz: float, cpu_share: float = 1.0) -> float:
    """A shot's floor (``last``: turn_and_shoot's ``last``): its first aim's turn on the
    time-optimal profile within the board files' limits, from standing to standing, + one
    frame of odometry (1 / ``hz``) + the camera's time at the shot's pose, over
    ``cpu_share`` when the driver that renders it runs under a CPU cap."""
    from esair_std.drivers.starfish.turn import profile_time

    turn = last.get("turn") or {}
    angle = math.radians(turn["deg"]) if "deg" in turn else float(last["bearing"]["bearing"])
    return profile_time(angle, *turn_limits()) + 1 / hz + camera_time(last["pose"]) / cpu_share
