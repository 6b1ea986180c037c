"""What the page needs to know of a MIN robot, from its validated board files: each
servo's limits and stand angle, the motions of its EEPROM image with their frames, the
foot sensors and their groups, the balance reaction's threshold, the tick, and the
actuator board's optional ``figure:`` (how to draw the robot)."""

from __future__ import annotations

import sys
from collections.abc import Mapping
from typing import cast

from esair_min.errors import EsairError
from esair_min.model.validate import load_robot
from esair_min.resources import resolve_robot

from ..drivers.minlink.budget import line_budget
from ..transport.codec import JSON, JSONObject

MINLINK = "esair_std.drivers.minlink:MinLink"


def robot_info(robot_arg: str) -> JSONObject:
    """The page's description of the robot of ``robot_arg`` (a bundled example's name,
    a folder, a board file). Raises EsairError when it cannot be loaded."""
    robot = load_robot(resolve_robot(robot_arg))
    names = [s.name for s in robot.servos]
    balance: JSONObject | None = None
    for r in robot.central.reactions:
        if r.kind == "balance":
            balance = {"name": r.name, "compare": list(r.compare), "threshold": r.threshold,
                       "samples": r.samples}
            break
    groups: dict[str, list[JSON]] = {}
    for s in robot.sensors:
        groups.setdefault(s.group, []).append(s.name)
    return {
        "name": robot.name,
        "tick_s": line_budget(robot).tick_s,
        "servos": [{"name": s.name, "index": s.index, "min": s.min_angle, "max": s.max_angle,
                    "stand": s.stand_angle, "speed": s.default_speed} for s in robot.servos],
        "motions": [{"name": m.name, "number": m.number, "delay_ticks": m.delay_ticks,
                     "frames": [dict(zip(names, f.angles, strict=True)) for f in m.frames]}
                    for m in robot.motions],
        "sensors": [{"name": s.name, "group": s.group, "min": s.min, "max": s.max}
                    for s in robot.sensors],
        "groups": {**groups},
        "balance": balance,
        # the board files' figure: section (None: the page shows the joints as dials)
        "figure": (robot.actuator.figure.model_dump(mode="json")
                   if robot.actuator is not None and robot.actuator.figure is not None else None),
    }


def entries_info(describe: Mapping[str, object]) -> tuple[JSONObject, list[str]]:
    """Robot descriptions of the MIN link entries of a ``describe`` answer, and the
    problems met (an entry whose board files cannot be read here gets generic panels)."""
    robots: JSONObject = {}
    problems: list[str] = []
    entries = cast("Mapping[str, Mapping[str, object]]", describe.get("entries") or {})
    for entry, d in entries.items():
        if d.get("class") != MINLINK:
            continue
        try:
            robots[entry] = robot_info(str(d.get("robot", entry)))
        except EsairError as exc:
            problems.append(f"{entry}: board files not readable here: {exc}")
    return robots, problems


def min_links(entries: Mapping[str, object]) -> list[str]:
    """The entries of a ``describe`` answer whose driver is a MinLink or a class derived
    from it (PAPA-MAN's MinLink, STARFISH's Starfish): each is a serial link the page's
    link bar shows, with or without board files the page can read. Run in the runtime:
    an entry checked in ``esair std run``'s checking child says ``link`` itself; else its
    class is looked up among the modules the runtime loaded, nothing is imported here."""
    base = getattr(sys.modules.get("esair_std.drivers.minlink.driver"), "MinLink", None)
    out = []
    for entry, d in entries.items():
        info = cast("Mapping[str, object]", d)                        # an entry: an object
        path = str(info.get("class", ""))
        module, _, name = path.partition(":")
        cls = getattr(sys.modules.get(module), name, None) if module in sys.modules else None
        if path == MINLINK or info.get("link") is True or (
                isinstance(base, type) and isinstance(cls, type) and issubclass(cls, base)):
            out.append(entry)
    return out
