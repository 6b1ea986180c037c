"""What STARFISH's simulated sensors see of the ONE world the emulated robot lives in
(:mod:`esair_min.world`, the room ``esair emulate starfish --room FILE`` is given): its
walls as numpy arrays in metres for vectorised ray casts (camera, radio, planner), its
landmarks as coloured vertical cylinders, its sound source and the radio's access point.

The room itself (walls, landmarks, their kinds) is esair_min.world's and only read here:
:meth:`Scene.from_world` takes an :class:`esair_min.world.Room` (millimetres). Its first
landmark of kind ``sound`` is the sound source (silent until switched on: the source's
place, level and on/off are the host's simulation, not the emulator's), the first of
kind ``access_point`` the radio's, every other landmark a pole in the palette's colours.

Units here are metres and radians; world frame x right, y up, angles counter-clockwise
from +x. Pure computation: no clock, no thread, no I/O.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Iterable, TypedDict

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from esair_min.world import Room

    from ...transport.codec import JSONObject

EPS = 1e-9

SOURCE_COLOR = (220, 30, 30)        # the sound source's marker in pictures: red
SOURCE_RADIUS = 0.08
SOURCE_HEIGHT = 0.5


class Pole(TypedDict):
    """A landmark the camera sees: a vertical cylinder (m) in an RGB colour."""
    x: float
    y: float
    r: float
    height: float
    color: tuple[int, int, int]


class SceneError(ValueError):
    """A scene description that cannot be used (the message says which field)."""


def _num(value: object, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise SceneError(f"{what} must be a finite number, not {value!r}")
    return float(value)


class Source:
    """The room's sound source: where it is, whether it sounds, its level (RMS, in
    full-scale units, heard at 1 m)."""

    __slots__ = ("x", "y", "on", "level")

    def __init__(self, x: float, y: float, on: bool = True, level: float = 0.1):
        self.x, self.y, self.on, self.level = float(x), float(y), bool(on), float(level)

    @classmethod
    def from_dict(cls, d: object, what: str = "source") -> "Source":
        if not isinstance(d, dict):
            raise SceneError(f"{what} must be a mapping with x, y (and on, level), not {d!r}")
        unknown = set(d) - {"x", "y", "on", "level"}
        if unknown:
            raise SceneError(f"{what}: unknown field {sorted(unknown)[0]!r} (known: x, y, on, level)")
        for k in ("x", "y"):
            if k not in d:
                raise SceneError(f"{what}: missing field {k!r}")
        on = d.get("on", True)
        if not isinstance(on, bool):
            raise SceneError(f"{what}.on must be true or false, not {on!r}")
        level = _num(d.get("level", 0.1), f"{what}.level")
        if not 0 < level <= 1:
            raise SceneError(f"{what}.level must be in (0, 1], not {level!r}")
        return cls(_num(d["x"], f"{what}.x"), _num(d["y"], f"{what}.y"), on, level)

    def to_dict(self) -> JSONObject:
        return {"x": self.x, "y": self.y, "on": self.on, "level": self.level}


class Scene:
    """Walls (segments), landmarks (cylinders), the sound source and the access point."""

    def __init__(self, walls: Iterable[Iterable[float]], landmarks: Iterable[Pole] = (),
                 source: Source | None = None, access_point: tuple[float, float] = (0.0, 0.0),
                 wall_height: float = 1.0):
        w = np.asarray([list(s) for s in walls], dtype=float)
        if w.ndim != 2 or w.shape[1] != 4 or len(w) == 0:
            raise SceneError("walls must be a list of [x1, y1, x2, y2] segments (at least one)")
        if not np.isfinite(w).all():
            raise SceneError("walls must hold finite numbers")
        self.walls = w
        self.a = w[:, 0:2]
        self.b = w[:, 2:4]
        if (np.hypot(*(self.b - self.a).T) < EPS).any():
            raise SceneError("a wall segment has zero length")
        self.landmarks = [lm.copy() for lm in landmarks]
        self.source = source if source is not None else Source(0.0, 0.0, on=False)
        self.access_point = (float(access_point[0]), float(access_point[1]))
        self.wall_height = float(wall_height)

    # --- rays -----------------------------------------------------------------
    def cast(self, origin: tuple[float, float], angles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """For rays from ``origin`` at ``angles`` (radians, world frame): the distance to
        the first wall each one meets (inf if none) and that wall's index (-1)."""
        o = np.asarray(origin, dtype=float)
        d = np.stack([np.cos(angles), np.sin(angles)], axis=-1)          # (n, 2)
        e = self.b - self.a                                              # (m, 2)
        ao = self.a - o                                                  # (m, 2)
        denom = d[:, None, 0] * e[None, :, 1] - d[:, None, 1] * e[None, :, 0]   # (n, m)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (ao[None, :, 0] * e[None, :, 1] - ao[None, :, 1] * e[None, :, 0]) / denom
            s = (ao[None, :, 0] * d[:, None, 1] - ao[None, :, 1] * d[:, None, 0]) / denom
        hit = (np.abs(denom) > EPS) & (t > EPS) & (s >= -EPS) & (s <= 1 + EPS)
        t = np.where(hit, t, np.inf)
        idx = np.argmin(t, axis=1)
        dist = t[np.arange(len(angles)), idx]
        return dist, np.where(np.isfinite(dist), idx, -1)

    def blocked(self, p: tuple[float, float], q: tuple[float, float]) -> bool:
        """True if the segment p-q crosses a wall (strictly between its ends)."""
        p_ = np.asarray(p, dtype=float)
        r = np.asarray(q, dtype=float) - p_
        length = float(np.hypot(*r))
        if length < EPS:
            return False
        dist, _ = self.cast(tuple(p_), np.array([math.atan2(r[1], r[0])]))
        return bool(dist[0] < length - 1e-6)

    def clearance(self, p: tuple[float, float]) -> float:
        """Distance from point p to the nearest wall."""
        pt = np.asarray(p, dtype=float)
        e = self.b - self.a
        u = np.clip(((pt - self.a) * e).sum(axis=1) / (e * e).sum(axis=1), 0.0, 1.0)
        nearest = self.a + u[:, None] * e
        return float(np.min(np.hypot(*(pt - nearest).T)))

    def bounds(self) -> tuple[float, float, float, float]:
        xs = np.concatenate([self.walls[:, 0], self.walls[:, 2]])
        ys = np.concatenate([self.walls[:, 1], self.walls[:, 3]])
        return float(xs.min()), float(ys.min()), float(xs.max()), float(ys.max())


def bearing_to(pose: tuple[float, float, float], x: float, y: float) -> float:
    """The bearing of point (x, y) as seen from ``pose`` (x, y, theta), in the robot's
    frame: radians in (-pi, pi], 0 straight ahead, positive to the left."""
    return wrap(math.atan2(y - pose[1], x - pose[0]) - pose[2])


def wrap(angle: float) -> float:
    """An angle in (-pi, pi]."""
    a = math.fmod(angle + math.pi, 2 * math.pi)
    if a <= 0:
        a += 2 * math.pi
    return a - math.pi


PALETTE = [(40, 160, 60), (230, 200, 40), (40, 90, 220), (200, 90, 200), (60, 200, 200)]


def from_world(world_room: Room, source_kind: str = "sound", radio_kind: str = "access_point",
               wall_height: float = 1.0) -> Scene:
    """The scene of an :class:`esair_min.world.Room` (millimetres; see the module
    docstring for the landmarks' kinds)."""
    walls = [[s.x0 / 1000, s.y0 / 1000, s.x1 / 1000, s.y1 / 1000] for s in world_room.walls]
    source, ap = None, None
    poles: list[Pole] = []
    for lm in world_room.landmarks:
        if lm.kind == source_kind and source is None:
            source = Source(lm.x / 1000, lm.y / 1000, on=False)
        elif lm.kind == radio_kind and ap is None:
            ap = (lm.x / 1000, lm.y / 1000)
        else:
            poles.append({"x": lm.x / 1000, "y": lm.y / 1000, "r": 0.12, "height": 0.8,
                          "color": PALETTE[len(poles) % len(PALETTE)]})
    return Scene(walls, poles, source, ap if ap is not None else (0.0, 0.0), wall_height)


def load_scene(path: str | Path) -> Scene:
    """The scene of a room file (esair_min.world.load_room: its errors name the file)."""
    from esair_min.world import load_room

    return from_world(load_room(path))
