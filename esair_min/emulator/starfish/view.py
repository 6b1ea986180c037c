"""The live view of STARFISH in its room (``esair emulate starfish --pty`` on a
terminal): the room's map in characters with the robot and its heading, the pose,
the wheels' rim speeds, the odometry polls and the last notices."""

from __future__ import annotations

import math
import os
import sys
import time
from typing import Any

#: The robot's heading as an arrow, by eighths of a turn from +x counter-clockwise.
ARROWS = ">/^\\<\\v/"


def room_map(sim: Any, width: int, height: int) -> list[str]:
    """The room (walls ``#``, landmarks ``*``, the robot's heading arrow) in
    ``width`` x ``height`` characters, +y up; a cell is twice as tall as wide."""
    x0, y0, x1, y1 = sim.world.room.bounds()
    if width < 4 or height < 3 or x1 <= x0 or y1 <= y0:
        return []
    scale = max((x1 - x0) / (width - 1), (y1 - y0) / (2 * (height - 1)))   # mm a column
    rows = max(2, min(height, round((y1 - y0) / (2 * scale)) + 1))
    cols = max(2, min(width, round((x1 - x0) / scale) + 1))
    grid = [[" "] * cols for _ in range(rows)]

    def put(x: float, y: float, ch: str) -> None:
        c = round((x - x0) / scale)
        r = rows - 1 - round((y - y0) / (2 * scale))
        if 0 <= r < rows and 0 <= c < cols:
            grid[r][c] = ch

    for w in sim.world.room.walls:
        n = max(2, int(math.hypot(w.x1 - w.x0, w.y1 - w.y0) / scale * 2))
        for k in range(n + 1):
            put(w.x0 + (w.x1 - w.x0) * k / n, w.y0 + (w.y1 - w.y0) * k / n, "#")
    for m in sim.world.room.landmarks:
        put(m.x, m.y, "*")
    p = sim.world.pose
    eighth = round(p.theta / (math.pi / 4)) % 8
    put(p.x, p.y, ARROWS[eighth])
    return ["".join(r) for r in grid]


def render(sim: Any, port: Any, width: int, height: int) -> list[str]:
    p = sim.world.pose
    wheels = "  ".join(f"{v:+6.0f}" for v in sim.drive.rim_speeds())
    head = [f"STARFISH  t {sim.now_s:8.2f} s  port {getattr(port, 'path', '')}"
            f"{'' if getattr(port, 'open', False) else ' (closed)'}",
            f"pose x {p.x:7.1f} mm  y {p.y:7.1f} mm  theta {math.degrees(p.theta):+7.1f} deg"
            f"  wall contacts {sim.world.collisions}",
            f"wheels (mm/s) {wheels}   odometry polls {sim.core.polls}"
            f"   watchdog stops {sim.core.watchdog_stops}"
            f"   drive writes {sim.i2c_writes} ({sim.i2c_dropped} dropped from the record)"]
    body = room_map(sim, width, height - len(head) - 1)
    return [line[:width] for line in head + [""] + body]


class StarfishView:
    """Repaints the terminal (alternate screen) at most ``hz`` times a second."""

    def __init__(self, sim: Any, port: Any, hz: float = 5.0, out: Any = None):
        self.sim, self.port, self.period = sim, port, 1.0 / hz
        self.out = out or sys.stdout
        self._next = 0.0

    def __enter__(self) -> StarfishView:
        self.out.write("\x1b[?1049h\x1b[?25l")
        self.poll()
        return self

    def __exit__(self, *exc: Any) -> None:
        self.out.write("\x1b[?25h\x1b[?1049l")
        self.out.flush()

    def poll(self) -> None:
        now = time.monotonic()
        if now < self._next:
            return
        self._next = now + self.period
        try:
            width, height = os.get_terminal_size(self.out.fileno())
        except (OSError, ValueError):
            width, height = 80, 24
        if width < 20 or height < 8:          # a terminal that says nothing useful
            width, height = 80, 24
        lines = render(self.sim, self.port, width, height)
        self.out.write("\x1b[H\x1b[2J" + "\r\n".join(lines))
        self.out.flush()
