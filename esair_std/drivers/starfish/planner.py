"""A path around the walls: A* on an occupancy grid of the room, then shortened.

Cells closer than ``margin`` to a wall are blocked (the robot is a disc). The grid path
(8-connected, diagonal steps cost sqrt 2) is shortened by dropping every waypoint that
the robot can skip on a straight line with the same margin to the walls. Used by the
``reconnect`` reaction to drive back to where the radio link was last up.
"""

from __future__ import annotations

import heapq
import math
from typing import cast

import numpy as np

from .scene import Scene


Point = tuple[float, float]      # m
Cell = tuple[int, int]          # (column, row) of the planner's grid


class NoPath(ValueError):
    """No way from start to goal keeps the margin to the walls."""


def _free_segment(room: Scene, p: Point, q: Point, margin: float, step: float) -> bool:
    if room.blocked(p, q):
        return False
    n = max(2, int(math.hypot(q[0] - p[0], q[1] - p[1]) / step) + 1)
    return all(room.clearance((p[0] + (q[0] - p[0]) * k / n, p[1] + (q[1] - p[1]) * k / n)) >= margin
               for k in range(n + 1))


def plan(room: Scene, start: tuple[float, float], goal: tuple[float, float], margin: float = 0.2,
         resolution: float = 0.1) -> list[tuple[float, float]]:
    """Waypoints from ``start`` (excluded) to ``goal`` (included); NoPath if none."""
    if _free_segment(room, start, goal, margin * 0.99, resolution / 2):
        return [(goal[0], goal[1])]
    x0, y0, x1, y1 = room.bounds()
    nx, ny = int(math.ceil((x1 - x0) / resolution)) + 1, int(math.ceil((y1 - y0) / resolution)) + 1
    xs = x0 + np.arange(nx) * resolution
    ys = y0 + np.arange(ny) * resolution
    free = np.array([[room.clearance((x, y)) >= margin for y in ys] for x in xs])

    def cell(p: Point) -> Cell:
        return (min(max(int(round((p[0] - x0) / resolution)), 0), nx - 1),
                min(max(int(round((p[1] - y0) / resolution)), 0), ny - 1))

    def nearest_free(c: Cell) -> Cell:
        if free[c]:
            return c
        idx = np.argwhere(free)
        if len(idx) == 0:
            raise NoPath("no cell of the room keeps the margin to the walls")
        # only free cells reachable in a straight line from the point itself
        order = np.argsort(np.hypot(idx[:, 0] - c[0], idx[:, 1] - c[1]))
        return cast(Cell, tuple(int(v) for v in idx[order[0]]))

    s, g = nearest_free(cell(start)), nearest_free(cell(goal))
    came: dict[Cell, Cell | None] = {s: None}
    cost = {s: 0.0}
    todo = [(0.0, s)]
    steps = [(dx, dy, math.hypot(dx, dy)) for dx in (-1, 0, 1) for dy in (-1, 0, 1) if dx or dy]
    while todo:
        _, c = heapq.heappop(todo)
        if c == g:
            break
        for dx, dy, w in steps:
            n = (c[0] + dx, c[1] + dy)
            if not (0 <= n[0] < nx and 0 <= n[1] < ny) or not free[n]:
                continue
            if dx and dy and not (free[c[0] + dx, c[1]] and free[c[0], c[1] + dy]):
                continue                                   # no corner cutting
            new = cost[c] + w
            if new < cost.get(n, math.inf):
                cost[n], came[n] = new, c
                heapq.heappush(todo, (new + math.hypot(g[0] - n[0], g[1] - n[1]), n))
    if g not in came:
        raise NoPath(f"no path from ({start[0]:.2f}, {start[1]:.2f}) to ({goal[0]:.2f}, "
                     f"{goal[1]:.2f}) keeps {margin} m from the walls")
    cells = []
    c = g
    while c is not None:
        cells.append((float(xs[c[0]]), float(ys[c[1]])))
        c = came[c]
    cells.reverse()
    points: list[tuple[float, float]] = [(start[0], start[1]), *cells[1:-1], (goal[0], goal[1])]
    # shorten: from each kept point jump to the farthest point in free line of sight
    out = []
    i = 0
    while i < len(points) - 1:
        j = len(points) - 1
        while j > i + 1 and not _free_segment(room, points[i], points[j], margin * 0.99, resolution / 2):
            j -= 1
        out.append(points[j])
        i = j
    return out
