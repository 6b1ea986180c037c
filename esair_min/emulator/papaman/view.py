"""A live terminal view of an emulated robot (rich): servos, sensors, the serial line.

Drawn on the terminal's alternate screen and repainted whole at every refresh, so a
resize never leaves an old copy behind; laid out for the terminal's current size
(two columns of servos from 56 columns on, one below that). Each servo shows its
angle, its target and its **recent motion**: one character per tick in which a servo
moved (the last ticks with motion, not the last seconds), so a 0.29 s dance shows in
full whatever the refresh rate. The serial line shows each line as the robot's
decoder received it with its own reply; ``!`` notices are rows of their own.
"""

from __future__ import annotations

import os
import signal
import sys
import time
from collections import deque
from types import FrameType
from typing import Any, Callable

from rich.text import Text

from esair_min.emulator.papaman.robot_sim import Emulator
from esair_min.emulator.transcript import Row

LEVELS = "▁▂▃▄▅▆▇█"
HISTORY_TICKS = 64        # ticks with motion kept per servo
IDLE_GAP_TICKS = 12       # a pause this long shows as a space in the history
TWO_COLUMNS_FROM = 56     # terminal width


class Motion:
    """Follows the servos tick by tick (``Emulator.on_tick``): the angles of the last
    ticks in which something moved, and the last motion played."""

    def __init__(self, emu: Emulator):
        self.emu = emu
        self.history: deque[tuple[int, ...] | None] = deque(maxlen=HISTORY_TICKS)
        self._last: tuple[int, ...] = tuple(emu.servo_angles)
        self._still = 0
        self.moving_ticks = 0                 # ticks with motion, in all
        self._playing: int | None = None
        self._started = 0
        self.last_played: tuple[str, int, float] | None = None   # name, ticks, end (s)
        emu.on_tick = self.tick

    def tick(self) -> None:
        emu = self.emu
        angles = tuple(emu.servo_angles)
        if angles != self._last:
            if self._still >= IDLE_GAP_TICKS and self.history:
                self.history.append(None)
            self.history.append(angles)
            self._last = angles
            self._still = 0
            self.moving_ticks += 1
        else:
            self._still += 1
        playing = emu.playing
        if playing != self._playing:
            if self._playing is not None:
                self.last_played = (self.name(self._playing), emu.ticks - self._started,
                                    emu.now_s)
            self._playing, self._started = playing, emu.ticks

    def name(self, number: int | None) -> str:
        return next((m.name for m in self.emu.robot.motions if m.number == number),
                    f"#{number}")

    def spark(self, i: int, lo: int, hi: int, width: int) -> str:
        cells = list(self.history)[-width:] if width > 0 else []
        out = []
        for angles in cells:
            if angles is None:
                out.append(" ")
            else:
                k = 0 if hi <= lo else round((angles[i] - lo) / (hi - lo) * (len(LEVELS) - 1))
                out.append(LEVELS[min(max(k, 0), len(LEVELS) - 1)])
        return "".join(out).rjust(max(width, 0))


def _fit(text: str, width: int) -> str:
    return text if len(text) <= width else text[:max(width - 1, 0)] + "…"


def render(emu: Emulator, motion: Motion, port, width: int, height: int) -> Text:
    """The whole screen for a terminal of ``width`` x ``height``."""
    robot = emu.robot
    lines: list[Text] = []
    state = ("open", "green") if port.open else (
        f"closed, {port.dropped} B dropped", "yellow")
    head = Text.assemble((robot.name, "bold"), f" {port.path} (", state,
                         f")  t {emu.now_s:.2f} s")
    if len(head) + 12 <= width:
        head.append(f"  tick {emu.ticks}")
    lines.append(head)
    playing = emu.playing
    what = (Text(f"playing {motion.name(playing)}", "bold green") if playing is not None
            else Text("idle", "dim"))
    faults = emu.faults.describe()
    if not emu.core.image_ok or faults != "none":      # never cut: said first
        what.append(f"  image {'ok' if emu.core.image_ok else 'BAD'}  faults: {faults}",
                    "bold red")
    if motion.last_played is not None:
        name, ticks, end = motion.last_played
        what.append(f"  last: {name}, {ticks} ticks ({ticks * emu.tick_s:.2f} s), "
                    f"{emu.now_s - end:.1f} s ago")
    if emu.core.image_ok and faults == "none" and len(what) + 20 <= width:
        what.append("  image ok, no faults", "dim")
    lines.append(what)
    lines += _servos(emu, motion, width)
    lines += _sensors(emu, width)
    errs = list(emu.errors)[-3:]
    err = Text(_fit("errors: " + ("  ".join(errs) if errs else "none"), width),
               "red" if errs else "dim")
    room = height - len(lines) - 2
    lines.append(Text(_fit("serial line: received → reply, notices apart", width), "bold"))
    rows = list(emu.transcript.rows) if emu.transcript is not None else []
    lines += _transcript(rows, width, max(room, 1))
    lines.append(err)
    out = Text()
    for i, line in enumerate(lines[:height]):
        line.truncate(width, overflow="ellipsis")
        if i:
            out.append("\n")
        out.append(line)
    return out


def _servos(emu: Emulator, motion: Motion, width: int) -> list[Text]:
    servos = emu.robot.servos
    if not servos:
        return []
    cols = 2 if width >= TWO_COLUMNS_FROM else 1
    colw = (width - 3 * (cols - 1)) // cols
    namew = max(len(s.name) for s in servos)
    spark = colw - namew - 10
    if spark < 4:                                   # very narrow: names give way
        namew = max(namew + spark - 4, 4)
        spark = 4
    angles, targets = emu.servo_angles, emu.servo_targets
    label = "recent motion" if spark >= 13 else ("motion" if spark >= 6 else "")
    head = f"{'servo':<{namew}} ang tgt  {label}"
    rows = [Text(" │ ".join([_fit(head, colw).ljust(colw)] * cols), "dim")]
    per = -(-len(servos) // cols)
    for r in range(per):
        row = Text()
        for c in range(cols):
            i = c * per + r
            if i >= len(servos):
                continue
            s = servos[i]
            if c:
                row.append(" │ ", "dim")
            moving = angles[i] != targets[i]
            row.append(f"{_fit(s.name, namew):<{namew}} ")
            row.append(f"{angles[i]:>3} {targets[i]:>3}", "yellow" if moving else "")
            row.append("  " + motion.spark(i, s.min_angle, s.max_angle, spark), "cyan")
        rows.append(row)
    return rows


def _sensors(emu: Emulator, width: int) -> list[Text]:
    items = [f"{s.name} {v}" for s, v in zip(emu.robot.sensors, emu.sensor_values)]
    if not items:
        return []
    out, line = [], "sensors "
    for item in items:
        if len(line) + len(item) + 2 > width and line.strip() != "sensors":
            out.append(Text(line.rstrip()))
            line = "        "
        line += item + "  "
    out.append(Text(line.rstrip()))
    return out


def _transcript(rows: list[Row], width: int, room: int) -> list[Text]:
    """The newest rows that fit in ``room`` lines, a long row folded under itself."""
    cmdw = min(max((len(r.text) for r in rows if r.kind == "line"), default=1), width // 3)
    out: list[Text] = []
    for row in reversed(rows):
        if row.kind == "notice":
            first = Text.assemble(("  notice ", "dim"), (" " * max(cmdw - 6, 0)),
                                  (row.text, "magenta"))
        else:
            reply = row.reply
            style = "dim" if reply is None else ("red" if reply.startswith("E") else "green")
            first = Text.assemble(f"  {_fit(row.text, cmdw):<{cmdw}} → ",
                                  (reply if reply is not None else "… (no reply yet)", style))
        folded = _fold(first, width, cmdw + 5)
        if len(out) + len(folded) > room:
            break
        out[:0] = folded
    return out


def _fold(text: Text, width: int, indent: int) -> list[Text]:
    if len(text) <= width or width <= indent + 8:
        return [text]
    parts = [text[:width]]
    rest = text[width:]
    while len(rest):
        step = width - indent
        piece = Text(" " * indent)
        piece.append_text(rest[:step])
        parts.append(piece)
        rest = rest[step:]
    return parts


class LiveView:
    """Refreshes a full-screen rich Live display at most ``hz`` times a second (call
    :meth:`poll`)."""

    def __init__(self, emu: Emulator, port, hz: float = 5.0):
        from rich.console import Console
        from rich.live import Live

        self.emu = emu
        self.port = port
        self.motion = Motion(emu)
        self.period = 1.0 / hz
        self._next = 0.0
        self._resize = False
        self._old_winch: Callable[[int, FrameType | None], Any] | int | None = None
        self.console = Console()
        self.live = Live(console=self.console, screen=True, auto_refresh=False,
                         redirect_stdout=False, redirect_stderr=False)

    def frame(self) -> Text:
        # the terminal's size now, asked of the terminal itself: COLUMNS/LINES in the
        # environment (which rich would prefer) do not follow a resize
        try:
            width, height = os.get_terminal_size(sys.stdout.fileno())
        except (OSError, ValueError):
            width, height = 80, 24
        self.console.size = (width, height)
        return render(self.emu, self.motion, self.port, width, height)

    def __enter__(self) -> "LiveView":
        self.live.__enter__()
        self.live.update(self.frame(), refresh=True)
        self._old_winch = signal.signal(signal.SIGWINCH, self._resized)
        return self

    def __exit__(self, *exc) -> None:
        signal.signal(signal.SIGWINCH, self._old_winch)
        self.live.__exit__(*exc)
        self.emu.on_tick = None

    def _resized(self, _signum=None, _frame=None) -> None:
        self._resize = True

    def poll(self) -> None:
        now = time.monotonic()
        if self._resize:
            # the terminal changed size: clear what it kept of the old screen and
            # repaint at once (cells beyond a narrower frame would show again later)
            self._resize = False
            self.console.clear()
            self._next = 0.0
        if now >= self._next:
            self._next = now + self.period
            self.live.update(self.frame(), refresh=True)
