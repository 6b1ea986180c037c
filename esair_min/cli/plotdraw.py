"""The figure of ``esair plot`` (matplotlib): a panel per joint, the feet below.

Joints whose names start with ``l_`` and ``r_`` stand side by side (left leg, right
leg), one small panel each, so two joints that move alike stay two curves; a robot
without such names fills the columns in servo order. Below, on the same time axis,
the foot sensors as the central board read them and, for each balance reaction, the
difference it compares with its threshold. Reactions that fired are red vertical
lines through every panel. The legend stands above the panels, outside the data.
"""

from __future__ import annotations

from typing import Any

from esair_min.model.robot import Robot

POSITION: dict[str, Any] = dict(color="tab:blue", linewidth=1.4)
TARGET: dict[str, Any] = dict(color="tab:orange", linewidth=1.0, linestyle="--")
REACTION: dict[str, Any] = dict(color="red", linewidth=0.9, linestyle=":")


def _columns(robot: Robot) -> list[list[int]]:
    """Servo indices per column: left leg, right leg (or servo order in two columns)."""
    names = [s.name for s in robot.servos]
    left = [i for i, n in enumerate(names) if n.startswith("l_")]
    right = [i for i, n in enumerate(names) if n.startswith("r_")]
    if left and len(left) == len(right) and len(left) + len(right) == len(names):
        return [left, right]
    half = -(-len(names) // 2)
    return [list(range(half)), list(range(half, len(names)))]


def _groups(robot: Robot) -> dict[str, list[int]]:
    groups: dict[str, list[int]] = {}
    for i, s in enumerate(robot.sensors):
        groups.setdefault(s.group, []).append(i)
    return groups


def draw(robot: Robot, ev: Any, ticks: list[int], pos: list[list[int]],
         tgt: list[list[int]], period: float, targets: bool, source: str):
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    servos = robot.servos
    cols = _columns(robot)
    rows = max(len(c) for c in cols)
    reactions = list(robot.central.reactions)
    feet = bool(robot.sensors)
    extra = (1 if feet else 0) + (1 if feet and reactions else 0)
    heights = [1.0] * rows + [1.3] * extra
    fig = plt.figure(figsize=(11, 1.45 * rows + 2.0 * extra + 1.2))
    grid = fig.add_gridspec(rows + extra, 2, height_ratios=heights, hspace=0.55, wspace=0.18)
    t = [k * period for k in ticks]
    fired = [k * period for k, _ in ev.reactions]
    first = None
    axes = []
    for c, idx in enumerate(cols):
        for r, i in enumerate(idx):
            ax = fig.add_subplot(grid[r, c], sharex=first)
            first = first or ax
            axes.append(ax)
            ax.plot(t, [p[i] for p in pos], **POSITION)
            if targets:
                ax.step(t, [g[i] for g in tgt], where="post", **TARGET)
            s = servos[i]
            lo, hi = s.min_angle, s.max_angle
            ys = [p[i] for p in pos] + ([g[i] for g in tgt] if targets else [])
            span = max(max(ys) - min(ys), 10)
            mid = (max(ys) + min(ys)) / 2
            ax.set_ylim(max(lo, mid - span * 0.7) - 2, min(hi, mid + span * 0.7) + 2)
            ax.set_title(s.name, fontsize=8, loc="left", pad=2)
            ax.tick_params(labelsize=7)
            ax.grid(True, alpha=0.3)
            if c == 0:
                ax.set_ylabel("deg", fontsize=7)
    below = rows
    if feet:
        ax = fig.add_subplot(grid[below, :], sharex=first)
        axes.append(ax)
        below += 1
        _feet(ax, robot, ev, period)
        if reactions:
            ax = fig.add_subplot(grid[below, :], sharex=first)
            axes.append(ax)
            _balance(ax, robot, ev, period)
    for ax in axes:
        for x in fired:
            ax.axvline(x, **REACTION)
    for ax in axes[:-1]:
        ax.tick_params(labelbottom=False)
    axes[-1].set_xlabel(f"time (s); one tick = {period * 1e3:.4g} ms", fontsize=8)
    handles = [Line2D([], [], **POSITION, label="simulated position")]
    if targets:
        handles.append(Line2D([], [], **TARGET, label="target"))
    if fired:
        names = sorted({name for _, name in ev.reactions})
        handles.append(Line2D([], [], **REACTION, label=f"reaction fired ({', '.join(names)})"))
    title = f"{robot.name}: servo angles from {source}"
    notes = 0
    if not ev.writes:
        title += ("\nno writes to the actuator board in this trace: the servos held the "
                  "stand pose throughout")
        notes = 1
    h = fig.get_figheight()
    fig.suptitle(title, fontsize=10, y=1 - 0.12 / h, va="top")
    fig.legend(handles=handles, loc="upper center", ncol=len(handles), fontsize=8,
               frameon=False, bbox_to_anchor=(0.5, 1 - (0.38 + 0.2 * notes) / h))
    fig.subplots_adjust(left=0.07, right=0.98, bottom=0.55 / h,
                        top=1 - (0.85 + 0.2 * notes) / h)
    return fig


def _feet(ax, robot: Robot, ev: Any, period: float) -> None:
    groups = _groups(robot)
    colors = ["tab:green", "tab:purple", "tab:brown", "tab:gray"]
    if not ev.readings:
        ax.text(0.5, 0.5, "no sensor readings in this trace (no reaction polled the feet)",
                transform=ax.transAxes, ha="center", va="center", fontsize=8, color="gray")
    for n, (name, idx) in enumerate(groups.items()):
        xs = [k * period for k, _ in ev.readings]
        ys = [sum(v[i] for i in idx if i < len(v)) for _, v in ev.readings]
        ax.step(xs, ys, where="post", marker=".", markersize=3, linewidth=1.1,
                color=colors[n % len(colors)], label=f"{name} (sum of {len(idx)})")
    ax.set_title("foot sensors as the central board read them (ADC counts)", fontsize=8,
                 loc="left", pad=2)
    ax.tick_params(labelsize=7)
    ax.grid(True, alpha=0.3)
    if ev.readings:
        ax.legend(fontsize=7, loc="lower right", bbox_to_anchor=(1.0, 0.98), frameon=False,
                  ncol=2, borderaxespad=0.1)


def _balance(ax, robot: Robot, ev: Any, period: float) -> None:
    groups = _groups(robot)
    for r in robot.central.reactions:
        a, b = (groups.get(g, []) for g in r.compare)
        xs = [k * period for k, _ in ev.readings]
        ys = [abs(sum(v[i] for i in a) - sum(v[i] for i in b)) for _, v in ev.readings]
        ax.step(xs, ys, where="post", marker=".", markersize=3, linewidth=1.1,
                color="tab:green", label=f"|{r.compare[0]} - {r.compare[1]}|")
        ax.axhline(r.threshold, color="black", linewidth=0.8, linestyle="--",
                   label=f"{r.name}: threshold {r.threshold}, {r.samples} polls in a row")
    ax.set_title("what the balance reaction compares", fontsize=8, loc="left", pad=2)
    ax.tick_params(labelsize=7)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, loc="lower right", bbox_to_anchor=(1.0, 0.98), frameon=False,
                  ncol=2, borderaxespad=0.1)
