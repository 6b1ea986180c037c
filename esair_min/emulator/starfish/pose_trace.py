"""STARFISH's trace: the room, then the true pose and the wheels' rim speeds at every
central tick, in virtual time (docs/trace-format.md, "STARFISH trace").

    # esair-starfish-trace 1
    wall 0 0 5000 0
    landmark speaker 4500 4500
    @0.009990 2500.0 2500.0 0.00000 0.0 0.0 0.0
    @0.019981 2500.0 2500.0 0.00000 -3.9 2.0 2.0 contact

Each ``@`` line: time (s), x, y (mm), theta (rad), the rim speed of each wheel (mm/s,
in wheel-index order), and ``contact`` when a wall stopped the robot in that tick.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TextIO

from esair_min.errors import EsairError
from esair_min.world import Landmark, Room, Segment

HEADER = "# esair-starfish-trace 1"


@dataclass(frozen=True)
class TraceRow:
    """One central tick of StarfishSim's trace: the time, the true pose, the wheels'
    rim speeds, and whether a wall stopped the robot since the last row."""

    t_s: float
    x: float
    y: float
    theta: float
    wheels: tuple[float, ...]
    collided: bool


def write_header(f: TextIO, room: Room) -> None:
    f.write(HEADER + "\n")
    for w in room.walls:
        f.write(f"wall {w.x0:g} {w.y0:g} {w.x1:g} {w.y1:g}\n")
    for m in room.landmarks:
        f.write(f"landmark {m.name} {m.x:g} {m.y:g}\n")


def write_rows(f: TextIO, rows: list) -> None:
    for r in rows:
        wheels = " ".join(f"{w:.1f}" for w in r.wheels)
        f.write(f"@{r.t_s:.6f} {r.x:.1f} {r.y:.1f} {r.theta:.5f} {wheels}"
                f"{' contact' if r.collided else ''}\n")


@dataclass
class StarfishTrace:
    room: Room
    t: list[float] = field(default_factory=list)
    x: list[float] = field(default_factory=list)
    y: list[float] = field(default_factory=list)
    theta: list[float] = field(default_factory=list)
    wheels: list[tuple[float, ...]] = field(default_factory=list)
    contacts: list[int] = field(default_factory=list)    # row indices


def is_starfish_trace(path: Path | str) -> bool:
    try:
        with open(path, encoding="ascii", errors="replace") as f:
            return f.readline().strip() == HEADER
    except OSError:
        return False


def read_trace(path: Path | str) -> StarfishTrace:
    try:
        lines = Path(path).read_text(encoding="ascii", errors="replace").splitlines()
    except OSError as exc:
        raise EsairError(f"cannot read the trace {path}: {exc.strerror}") from None
    if not lines or lines[0].strip() != HEADER:
        raise EsairError(f"{path}: not a STARFISH trace (its first line must be '{HEADER}')")
    walls, marks = [], []
    tr = StarfishTrace(Room(()))
    for no, line in enumerate(lines[1:], start=2):
        parts = line.split()
        if not parts:
            continue
        try:
            if parts[0] == "wall":
                walls.append(Segment(*(float(v) for v in parts[1:5])))
            elif parts[0] == "landmark":
                marks.append(Landmark(parts[1], float(parts[2]), float(parts[3])))
            elif parts[0].startswith("@"):
                contact = parts[-1] == "contact"
                nums = [float(v) for v in ([parts[0][1:]] + parts[1:-1 if contact else None])]
                if len(nums) < 4:
                    raise ValueError
                if contact:
                    tr.contacts.append(len(tr.t))
                tr.t.append(nums[0])
                tr.x.append(nums[1])
                tr.y.append(nums[2])
                tr.theta.append(nums[3])
                tr.wheels.append(tuple(nums[4:]))
            else:
                raise ValueError
        except (ValueError, TypeError, IndexError):
            raise EsairError(f"{path}:{no}: not a STARFISH trace line: {line.strip()!r}") from None
    tr.room = Room(tuple(walls), tuple(marks))
    return tr
