"""PAPA-MAN's part of ``esair emulate`` (:class:`~esair_min.emulator.serve.RobotRun`): the
boards with a scenario, faults and an EEPROM image; SIGUSR1 plays the scenario while
served; the live view of servos and sensors."""

from __future__ import annotations

import signal
from contextlib import ExitStack
from typing import Any, TextIO

from esair_min.emulator.papaman.robot_sim import Emulator
from esair_min.errors import EsairError
from esair_min.model.robot import Robot


class PapamanRun:
    """The emulated boards of a robot with servo and sensor boards (PAPA-MAN)."""

    run_from_boot = False

    @staticmethod
    def refuse(opts: Any) -> None:
        """Options for a robot with an omni base only."""
        for flag, given in (("--room", opts.room), ("--pose", opts.pose),
                            ("--world-out", opts.world_out)):
            if given is not None:
                raise EsairError(f"{flag} is for a robot with an omni base (STARFISH); this "
                                 "robot has none")

    def __init__(self, robot: Robot, opts: Any, stack: ExitStack, image: bytes | None,
                 trace: TextIO | None, instance: str | None, live: bool):
        writer = None
        if trace is not None:
            from esair_min.emulator.tracefile import FileTraceWriter

            writer = FileTraceWriter(trace)
            writer.rx_lines = opts.trace_rx
        self.sim = Emulator(robot, scenario=opts.scenario, faults=opts.faults, trace=writer,
                            eeprom_image=image, transcript=live, instance=instance,
                            hold_scenario=opts.hold_scenario, eeprom_file=opts.eeprom)
        stack.callback(self.sim.close)
        self._play = False
        self._old: Any = None

    def _on_usr1(self, _signum: int | None = None, _frame: object = None) -> None:
        self._play = True

    def install(self) -> None:
        """SIGUSR1 while serving: the scenario plays (again) from its start, at the serve
        loop's next turn (the handler only sets a flag)."""
        self._old = signal.signal(signal.SIGUSR1, self._on_usr1)

    def restore(self) -> None:
        signal.signal(signal.SIGUSR1, self._old)

    def idle(self) -> None:
        if self._play:
            self._play = False
            self.sim.play_scenario()

    def view(self, port: Any, out: TextIO) -> Any:
        from esair_min.emulator.papaman.view import LiveView

        return LiveView(self.sim, port)

    def flush(self) -> None:
        """The trace writer writes each line as it comes."""

    def closing(self) -> str | None:
        return None
