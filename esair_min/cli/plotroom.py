"""``esair plot`` of a STARFISH trace: the robot's path on the room's map (walls,
landmarks, start and end, wall contacts), and the wheels' rim speeds over time."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from esair_min.emulator.starfish.pose_trace import read_trace


def plot_room(trace: Path | str, output: Path | str) -> int:
    """Draw ``trace`` into the PNG ``output``; return the number of rows drawn."""
    import matplotlib.pyplot as plt

    fig, rows = room_figure(trace)
    fig.savefig(output, dpi=90)
    plt.close(fig)
    return rows


def room_figure(trace: Path | str) -> tuple[Any, int]:
    """The figure of ``trace`` (matplotlib's, Agg) and the number of rows drawn. Laid out
    by matplotlib's constrained layout, which keeps the legend beside the map inside the
    figure (tight_layout left it cut at the right edge: "path (true pos")."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tr = read_trace(trace)
    fig, (room_ax, wheel_ax) = plt.subplots(
        2, 1, figsize=(7, 9), gridspec_kw={"height_ratios": [3, 1]}, layout="constrained")
    for w in tr.room.walls:
        room_ax.plot([w.x0 / 1000, w.x1 / 1000], [w.y0 / 1000, w.y1 / 1000], color="black",
                     linewidth=2)
    for m in tr.room.landmarks:
        room_ax.plot(m.x / 1000, m.y / 1000, marker="*", color="tab:orange", markersize=12)
        room_ax.annotate(m.name, (m.x / 1000, m.y / 1000), textcoords="offset points",
                         xytext=(6, 6))
    if tr.t:
        xs = [x / 1000 for x in tr.x]
        ys = [y / 1000 for y in tr.y]
        room_ax.plot(xs, ys, color="tab:blue", linewidth=1.2, label="path (true pose)")
        room_ax.plot(xs[0], ys[0], marker="o", color="tab:green", label="start")
        room_ax.plot(xs[-1], ys[-1], marker="s", color="tab:red", label="end")
        if tr.contacts:
            room_ax.plot([xs[i] for i in tr.contacts], [ys[i] for i in tr.contacts], "x",
                         color="tab:red", label="wall contact")
        for k in range(len(tr.wheels[0])):
            wheel_ax.plot(tr.t, [w[k] for w in tr.wheels], label=f"wheel {k}")
    room_ax.set_aspect("equal")
    room_ax.set_xlabel("x (m)")
    room_ax.set_ylabel("y (m)")
    room_ax.set_title(f"STARFISH in its room: {len(tr.t)} ticks, "
                      f"{tr.t[-1] if tr.t else 0:.1f} s")
    room_ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    wheel_ax.set_xlabel("time (s)")
    wheel_ax.set_ylabel("rim speed (mm/s)")
    if tr.t:
        wheel_ax.legend(fontsize=8)
    return fig, len(tr.t)
