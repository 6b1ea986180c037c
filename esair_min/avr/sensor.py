"""The sensor board's firmware alone in the simavr driver: how long one full read of
every sensor takes (issue 24: papaman-avr's eight feet through the 74HC4051).

The board runs as the driver's only node (no TWI master: nothing interrupts the
superloop), its mux modelled as the board file declares it (``mux`` line, see
``simdrv.c``); each execution of ``hal_regs_publish`` (a reading stored in the register
map) is recorded, so a round is the cycles from one publish of the first sensor to the
next. Exact: the driver is cycle-accurate and deterministic.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from esair_min.avr.simavr_harness import SimError, mux_line, parse_events, run_commands, symbol
from esair_min.model.robot import Robot

#: The node the sensor board is when it runs alone.
ALONE = 0


@dataclass(frozen=True)
class SensorRounds:
    """The publishes of a run and the rounds they make."""

    sensors: int
    publishes: tuple[int, ...]        # cycles of each hal_regs_publish call
    early: int                        # conversions started before the mux settled

    @property
    def rounds(self) -> tuple[int, ...]:
        """Cycles of each full read (every sensor once), from the first publish on."""
        p, n = self.publishes, self.sensors
        return tuple(p[i + n] - p[i] for i in range(0, len(p) - n, n))


def sensor_rounds(robot: Robot, elf: Path, cycles: int, settle_cycles: int | None = None
                  ) -> SensorRounds:
    """Run the sensor board firmware ``elf`` alone for ``cycles``; ``settle_cycles``
    overrides the mux model's settling time (None: the board file's)."""
    board = robot.sensor_board
    if board is None:
        raise SimError("the robot has no sensor board")
    mux = mux_line(robot, ALONE)
    if mux and settle_cycles is not None:
        mux = [" ".join(mux[0].split()[:-1] + [str(settle_cycles)])]
    cmds = [*mux, f"watch {ALONE} {symbol(elf, 'hal_regs_publish')}", f"run {cycles}", "quit"]
    run = parse_events(run_commands(elf, cmds, ""), scl_cycles=1)
    return SensorRounds(len(board.sensors), tuple(c for c, _ in run.hits), len(run.mux_early))
