"""The serial line's time budget, computed from the robot's board (:mod:`.board`).

A byte is 10 bit times on the wire (8N1) at the central board's declared ``uart.baud``.
The link keeps one command in flight, so one exchange costs the command line, the
robot's own work before it answers, and the reply line. The feet are polled with ``s``,
whose reply is the longest a sensor board can send (every reading at its maximum); the
poll may use at most ``share`` of the line (default half), the rest is for commands.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .board import Board, board_of
from .commands import RobotCommands
from .link_errors import LinkError

if TYPE_CHECKING:  # pragma: no cover - the model is loaded by whoever opens a link
    from esair_min.model.robot import Robot

BITS_PER_BYTE = 10          # start + 8 data + stop
DEFAULT_FEET_SHARE = 0.5
#: Seconds from a command's arrival to its line written, when ``deadline`` is not given.
DEFAULT_DEADLINE_S = 0.5


class LineBudget:
    """Wire times of one robot's link. (A plain class, not a dataclass: ``dataclasses``
    imports ``inspect`` and ``ast`` into the robot side.)"""

    __slots__ = ("baud", "tick_s", "sensor_read_s", "feet_request_bytes", "feet_reply_bytes")

    def __init__(self, baud: int, tick_s: float, sensor_read_s: float,
                 feet_request_bytes: int, feet_reply_bytes: int):
        self.baud = baud
        self.tick_s = tick_s
        self.sensor_read_s = sensor_read_s          # the central board's I2C read for `s`
        self.feet_request_bytes = feet_request_bytes   # "s" (+ "*HH") + CR LF
        self.feet_reply_bytes = feet_reply_bytes       # "OK " + the longest readings + CR LF

    def __repr__(self) -> str:
        return "LineBudget(" + ", ".join(f"{k}={getattr(self, k)!r}" for k in self.__slots__) + ")"

    def line_s(self, nbytes: int) -> float:
        return nbytes * BITS_PER_BYTE / self.baud

    @property
    def feet_exchange_s(self) -> float:
        """Worst-case time of one ``s`` exchange, command line to the reply's last byte."""
        return (self.line_s(self.feet_request_bytes) + self.sensor_read_s
                + self.line_s(self.feet_reply_bytes))

    def max_feet_hz(self, share: float = DEFAULT_FEET_SHARE) -> float:
        return share / self.feet_exchange_s

    def check_feet_hz(self, hz: float, share: float = DEFAULT_FEET_SHARE) -> None:
        """Refuse a poll rate the line cannot carry within ``share`` of its time."""
        if not 0 < share <= 1:
            raise LinkError(f"feet share {share:g} must be more than 0 and at most 1")
        if not hz > 0:
            raise LinkError(f"feet poll rate {hz:g} Hz must be more than 0")
        most = self.max_feet_hz(share)
        if hz > most:
            raise LinkError(
                f"feet poll rate {hz:g} Hz exceeds the line's budget: at {self.baud} baud one "
                f"'s' exchange takes up to {self.feet_exchange_s * 1e3:.1f} ms "
                f"({self.feet_request_bytes} bytes out, {self.feet_reply_bytes} back), so "
                f"{share:.0%} of the line allows at most {most:.1f} Hz")

    def command_s(self, line_bytes: int, reply_bytes: int, waits_tick: bool) -> float:
        """Least time of one exchange in a stream of equal commands, one in flight: the
        line out up to its CR, (for actuator writes) the wait for the next tick, the reply
        back. The LF after the CR travels while the reply comes back (full duplex)."""
        t = self.line_s(line_bytes - 1) + self.line_s(reply_bytes)
        if waits_tick:
            ticks = int(t // self.tick_s) + 1     # the write waits for the tick after the line
            t = ticks * self.tick_s
        return t


def line_budget(robot: Board | Robot) -> LineBudget:
    board = board_of(robot)
    cmds = RobotCommands(board)
    request = len(cmds.wire(cmds.prefix("sensors")))
    digits = [len(str(s.max)) for s in board.sensors] or [0]
    reply = len("OK ") + sum(digits) + max(len(digits) - 1, 0) + 2
    regs = board.sensor_registers
    bits = 1 + 9 + 9 + 1 + 9 + 9 * regs + 1 if regs else 0
    read_s = bits / board.i2c_hz if board.i2c_hz else 0.0
    return LineBudget(board.baud, board.tick_s, read_s, request, reply)
