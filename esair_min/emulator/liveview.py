"""A live terminal view of an emulated robot (rich): servos, sensors, lines, errors."""

from __future__ import annotations

import time

from rich.console import Group
from rich.table import Table
from rich.text import Text

from esair_min.emulator.robot import Emulator

BAR = 20


def _bar(angle: int, lo: int, hi: int) -> str:
    if hi <= lo:
        return ""
    k = round((angle - lo) / (hi - lo) * (BAR - 1))
    k = min(max(k, 0), BAR - 1)
    return "·" * k + "█" + "·" * (BAR - 1 - k)


def render(emu: Emulator, path: str = "") -> Group:
    robot = emu.robot
    motion = next((m.name for m in robot.motions if m.number == emu.playing), None)
    head = Text.assemble(
        (f"{robot.name} ", "bold"), (path + "  " if path else ""),
        f"t={emu.now_s:8.2f}s  tick {emu.ticks}  ",
        ("playing " + motion if motion else "idle", "green" if motion else "dim"),
        f"  image {'ok' if emu.core.image_ok else 'BAD'}  faults: {emu.faults.describe()}")
    servos = Table(title="servos", title_justify="left", expand=False, box=None)
    for col in ("#", "name", "angle", "target", ""):
        servos.add_column(col)
    angles, targets = emu.servo_angles, emu.servo_targets
    for i, s in enumerate(robot.servos):
        servos.add_row(str(s.index), s.name, str(angles[i]), str(targets[i]),
                       _bar(angles[i], s.min_angle, s.max_angle))
    sensors = Table(title="sensors", title_justify="left", box=None)
    sensors.add_column("name")
    sensors.add_column("value")
    for s, v in zip(robot.sensors, emu.sensor_values):
        sensors.add_row(s.name, str(v))
    lines = Table(title="serial line", title_justify="left", box=None)
    lines.add_column("commands (PC → robot)")
    lines.add_column("replies (robot → PC)")
    cmds, reps = list(emu.commands.last)[-8:], list(emu.replies.last)[-8:]
    for k in range(max(len(cmds), len(reps))):
        lines.add_row(cmds[k] if k < len(cmds) else "", reps[k] if k < len(reps) else "")
    errs = list(emu.errors)[-5:]
    err_text = Text("errors: " + ("  ".join(errs) if errs else "none"),
                    style="red" if errs else "dim")
    top = Table.grid(padding=(0, 4))
    top.add_row(servos, sensors)
    return Group(head, top, lines, err_text)


class LiveView:
    """Refreshes a rich Live display at most ``hz`` times a second (call :meth:`poll`)."""

    def __init__(self, emu: Emulator, port, hz: float = 5.0):
        from rich.live import Live

        self.emu = emu
        self.path = port.path
        self.period = 1.0 / hz
        self._next = 0.0
        self.live = Live(render(emu, path), auto_refresh=False, transient=False)

    def __enter__(self) -> "LiveView":
        self.live.__enter__()
        return self

    def __exit__(self, *exc) -> None:
        self.live.__exit__(*exc)

    def poll(self) -> None:
        now = time.monotonic()
        if now >= self._next:
            self._next = now + self.period
            self.live.update(render(self.emu, self.path), refresh=True)
