"""The serial line's time budget, computed from the robot's validated model.

A byte is 10 bit times on the wire (8N1) at the central board's declared ``uart.baud``.
The link keeps one command in flight, so one exchange costs the command line, the
robot's own work before it answers, and the reply line. The feet are polled with ``s``,
whose reply is the longest a sensor board can send (every reading at its maximum); the
poll may use at most ``share`` of the line (default half), the rest is for commands.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from .commands import RobotCommands
from .link_errors import LinkError

if TYPE_CHECKING:  # pragma: no cover - the model is loaded by whoever opens a link
    from esair_min.model.robot import Robot

BITS_PER_BYTE = 10          # start + 8 data + stop
DEFAULT_FEET_SHARE = 0.5


@dataclass(frozen=True)
class LineBudget:
    """Wire times of one robot's link."""

    baud: int
    tick_s: float
    sensor_read_s: float      # the central board's I2C read of the sensor board for `s`
    feet_request_bytes: int   # "s" (+ "*HH") + CR LF
    feet_reply_bytes: int     # "OK " + the longest readings + CR LF

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


def line_budget(robot: Robot) -> LineBudget:
    central = robot.central
    assert central.uart is not None and central.timer2 is not None
    cmds = RobotCommands(robot)
    request = len(cmds.wire(cmds.prefix("sensors")))
    digits = [len(str(s.max)) for s in robot.sensors] or [0]
    reply = len("OK ") + sum(digits) + max(len(digits) - 1, 0) + 2
    peer = robot.peer("sensor")
    regs = peer.registers if peer is not None else 0
    bits = 1 + 9 + 9 + 1 + 9 + 9 * regs + 1 if regs else 0
    read_s = bits / central.i2c.speed_hz if central.i2c else 0.0
    return LineBudget(central.uart.baud, central.timer2.period_s, read_s, request, reply)
