"""The room: wall segments and landmarks, loaded from a small YAML file or made."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from esair_min.errors import ConfigError, file_mark

#: The default room: 5 m x 5 m, corner at the origin (room for a 4 m square drive).
DEFAULT_SIZE_MM = (5000.0, 5000.0)


@dataclass(frozen=True)
class Segment:
    """A wall from (x0, y0) to (x1, y1), mm."""

    x0: float
    y0: float
    x1: float
    y1: float

    def closest(self, x: float, y: float) -> tuple[float, float]:
        """The point of the segment nearest (x, y)."""
        dx, dy = self.x1 - self.x0, self.y1 - self.y0
        n = dx * dx + dy * dy
        t = 0.0 if n == 0 else max(0.0, min(1.0, ((x - self.x0) * dx + (y - self.y0) * dy) / n))
        return self.x0 + t * dx, self.y0 + t * dy

    def distance(self, x: float, y: float) -> float:
        cx, cy = self.closest(x, y)
        return math.hypot(x - cx, y - cy)


@dataclass(frozen=True)
class Landmark:
    """A named point of the room (a sound source, a target for the camera...), mm."""

    name: str
    x: float
    y: float
    kind: str = "mark"


@dataclass(frozen=True)
class Room:
    """Walls and landmarks of one room."""

    walls: tuple[Segment, ...]
    landmarks: tuple[Landmark, ...] = ()

    @classmethod
    def box(cls, width_mm: float, depth_mm: float,
            landmarks: tuple[Landmark, ...] = ()) -> Room:
        """A rectangular room with its corner at the origin."""
        w, d = float(width_mm), float(depth_mm)
        walls = (Segment(0, 0, w, 0), Segment(w, 0, w, d), Segment(w, d, 0, d),
                 Segment(0, d, 0, 0))
        return cls(walls, landmarks)

    @classmethod
    def default(cls) -> Room:
        return cls.box(*DEFAULT_SIZE_MM)

    def clearance(self, x: float, y: float) -> float:
        """Distance from (x, y) to the nearest wall, mm (inf in a room without walls)."""
        return min((w.distance(x, y) for w in self.walls), default=math.inf)

    def ray(self, x: float, y: float, angle: float, max_mm: float = math.inf) -> float:
        """Distance along the ray from (x, y) at ``angle`` (rad) to the first wall it
        meets, or ``max_mm`` when none is nearer."""
        dx, dy = math.cos(angle), math.sin(angle)
        best = max_mm
        for w in self.walls:
            ex, ey = w.x1 - w.x0, w.y1 - w.y0
            den = dx * ey - dy * ex
            if abs(den) < 1e-12:
                continue
            t = ((w.x0 - x) * ey - (w.y0 - y) * ex) / den
            u = ((w.x0 - x) * dy - (w.y0 - y) * dx) / den
            if t >= 0 and 0 <= u <= 1:
                best = min(best, t)
        return best

    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the walls and landmarks."""
        xs = [v for w in self.walls for v in (w.x0, w.x1)] + [m.x for m in self.landmarks]
        ys = [v for w in self.walls for v in (w.y0, w.y1)] + [m.y for m in self.landmarks]
        if not xs:
            return 0.0, 0.0, 0.0, 0.0
        return min(xs), min(ys), max(xs), max(ys)


def _number(value: object, where: str, path: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ConfigError(f"{where} must be a finite number of mm, not {value!r}", file_mark(path))
    return float(value)


def load_room(path: Path | str) -> Room:
    """A room from YAML: ``box: [width, depth]`` and/or ``walls: [[x0, y0, x1, y1], ...]``,
    and ``landmarks: [{name, x, y, kind}]`` (mm). Errors name the file."""
    import yaml

    p = str(path)
    try:
        data = yaml.safe_load(Path(path).read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise ConfigError(f"cannot read the room: {exc}", file_mark(p)) from None
    if not isinstance(data, dict):
        raise ConfigError("a room file is a mapping with 'box', 'walls' and 'landmarks'",
                          file_mark(p))
    unknown = sorted(set(data) - {"box", "walls", "landmarks"})
    if unknown:
        raise ConfigError(f"unknown key '{unknown[0]}' in a room file (allowed: box, walls, "
                          "landmarks)", file_mark(p))
    walls: list[Segment] = []
    if "box" in data:
        box = data["box"]
        if not isinstance(box, list) or len(box) != 2:
            raise ConfigError("'box' is [width, depth] in mm", file_mark(p))
        w, d = (_number(v, "'box'", p) for v in box)
        if w <= 0 or d <= 0:
            raise ConfigError("'box' needs a width and a depth above 0 mm", file_mark(p))
        walls += Room.box(w, d).walls
    for i, seg in enumerate(data.get("walls") or []):
        if not isinstance(seg, list) or len(seg) != 4:
            raise ConfigError(f"wall {i} is [x0, y0, x1, y1] in mm", file_mark(p))
        walls.append(Segment(*(_number(v, f"wall {i}", p) for v in seg)))
    marks = []
    for i, m in enumerate(data.get("landmarks") or []):
        if not isinstance(m, dict) or not {"name", "x", "y"} <= set(m) \
                or not set(m) <= {"name", "x", "y", "kind"}:
            raise ConfigError(f"landmark {i} is {{name, x, y, kind}}", file_mark(p))
        marks.append(Landmark(str(m["name"]), _number(m["x"], f"landmark {i} x", p),
                              _number(m["y"], f"landmark {i} y", p), str(m.get("kind", "mark"))))
    if not walls:
        raise ConfigError("a room needs walls: give 'box' or 'walls'", file_mark(p))
    return Room(tuple(walls), tuple(marks))
