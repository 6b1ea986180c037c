"""``esair std top``: a live view (rich) of a running robot's components, their states
and rates (steps, samples, commands per second), refreshed from the control endpoint."""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

import click

from ..errors import StdError
from .control import Caller, _Connection, control, stopped_line

if TYPE_CHECKING:  # pragma: no cover
    from rich.table import Table

#: a row of ``ls``'s answer as the live table reads and extends it (count, label...)
Row = dict[str, Any]

COLOURS = {"running": "green", "ready": "green", "busy": "yellow", "starting": "cyan",
           "failed": "bold red", "lost": "bold red", "stopped": "dim"}


def _rate_source(kind: str, counters: Row) -> int:
    if kind in ("behavior", "reaction"):
        return int(counters.get("steps", 0)) + sum(
            int(v.get("received", 0)) for v in counters.values() if isinstance(v, dict))
    return int(counters.get("reported", 0)) + int(counters.get("commands", 0))


#: Columns of the reason at most (the rest of a long reason: `esair std inspect NAME`).
REASON_WIDTH = 48
#: A driver's children sharing a prefix (``papaman.servo.*``) become one row from this many.
GROUP_FROM = 3


def snapshot(c: Caller) -> list[Row]:
    rows: list[Row] = []
    for row in c.call("ls", {"all": True}):
        if row["kind"] == "driver":
            row["count"] = 0
            rows.append(row)
            continue
        try:
            info = c.call("inspect", {"name": row["name"]})
        except StdError:
            # no answer in time, or removed since the listing (the next listing drops
            # it): the row stays, its rate unknown
            row["count"] = None
        else:
            row["count"] = _rate_source(row["kind"], info.get("counters", {}))
        rows.append(row)
    return grouped(rows)


def grouped(rows: list[Row]) -> list[Row]:
    """A driver's children under it, shown by their name within it (``.motion``);
    children sharing a prefix, GROUP_FROM or more, as one row (``.servo.* (12)``) whose
    state is the worst of theirs (``ready``, or e.g. ``lost 3/12``) and count their sum."""
    prefix_n: dict[tuple[str, str], int] = {}
    for r in rows:
        if r.get("parent"):
            prefix_n[(r["parent"], r["name"].rpartition(".")[0])] = prefix_n.get(
                (r["parent"], r["name"].rpartition(".")[0]), 0) + 1
    out: list[Row] = []
    groups: dict[str, Row] = {}
    for r in rows:
        parent = r.get("parent")
        if not parent:
            out.append(r)
            continue
        prefix = r["name"].rpartition(".")[0]
        n = prefix_n[(parent, prefix)]
        if n < GROUP_FROM or prefix == parent:
            out.append(dict(r, label="  " + r["name"][len(parent):]))
            continue
        g = groups.get(prefix)
        if g is None:
            g = groups[prefix] = dict(r, name=prefix + ".*", count=0, bad=0, n=n,
                                      label=f"  {prefix[len(parent):]}.* ({n})")
            out.append(g)
        g["count"] = None if g["count"] is None or r["count"] is None else (
            g["count"] + r["count"])
        if r["state"] != "ready":
            g["bad"] += 1
            g["reason"] = g.get("reason") or r.get("reason", "")
            g["state"] = f"{r['state']} {g['bad']}/{n}"
    return out


def render(rows: list[Row], before: dict[str, tuple[float, int]], robot: str) -> Table:
    from rich.table import Table
    from rich.text import Text
    now = time.monotonic()
    cells: list[tuple[str, ...]] = []
    for r in rows:
        if r["count"] is None:              # its counters did not come in time
            rate = "?"
        else:
            t0, n0 = before.get(r["name"], (now, r["count"]))
            rate = f"{(r['count'] - n0) / (now - t0) if now > t0 else 0.0:.0f}"
            before[r["name"]] = (now, r["count"])
        cells.append((r["label"] if "label" in r else r["name"], r["kind"], r["state"],
                      str(r["pid"]), r["host"], str(r.get("restarts", 0)), rate,
                      r.get("reason", "")))
    t = Table(title=f"ESAIR STD — robot {robot}", expand=False)
    for i, col in enumerate(COLUMNS):
        # One line a row: every column keeps its width, a long reason is cut (`esair std
        # inspect NAME` has it whole).
        width = max([len(col)] + [len(c[i]) for c in cells])
        t.add_column(col, justify="right" if col in ("pid", "restarts", "events/s") else "left",
                     no_wrap=col != "reason", overflow="ellipsis",
                     min_width=None if col == "reason" else width,
                     max_width=REASON_WIDTH if col == "reason" else None)
    for c in cells:
        colour = COLOURS.get(c[2].split()[0], "white")
        # the reason's column may narrow (it is the one that gives way), its text stays
        # on one line
        t.add_row(*c[:2], f"[{colour}]{c[2]}[/]", *c[3:7],
                  Text(c[7], no_wrap=True, overflow="ellipsis"))
    return t


COLUMNS = ("name", "kind", "state", "pid", "host", "restarts", "events/s", "reason")


@click.command("top")
@click.option("--interval", type=click.FloatRange(min=0.1), default=1.0, show_default=True,
              help="Seconds between refreshes.")
@click.option("--count", type=click.IntRange(min=1), default=None,
              help="Stop after this many refreshes (default: until Ctrl-C).")
@control
def top_cmd(c: _Connection, interval: float, count: int | None) -> None:
    """Live table of components: state, pid, host, restarts and events per second."""
    from rich.console import Console
    from rich.live import Live
    before: dict[str, tuple[float, int]] = {}
    console = Console()
    n = 0

    def robot() -> str:          # while it starts, its list grows: the title says so
        ping = c.call("ping")      # and while it is STOPPED, who stopped it and when
        title = f"{c.robot} (starting)" if ping.get("starting") else c.robot
        return title + stopped_line(ping.get("stopped"), " — ")

    with Live(render(snapshot(c), before, robot()), console=console,
              auto_refresh=False) as live:
        try:
            while count is None or n < count:
                time.sleep(interval)
                live.update(render(snapshot(c), before, robot()), refresh=True)
                n += 1
        except KeyboardInterrupt:
            pass
