"""STARFISH's MIN link: the omni base's command set (docs/protocol.md, "STARFISH") on
the same :class:`~esair_std.drivers.minlink.Link` as PAPA-MAN's, and the resources it
gives: the wheels actuator and the odometry sensor (the notices are MinLink's).

- :class:`OmniCommands`: the lines (``V``, ``x``, ``O``, ``v``), which reply can answer
  which line (the link matches replies by shape), and the ``v`` check (wheels, flow
  sensors, checksum setting of the board files);
- :func:`omni_budget`: the line's time budget at the central board's baud;
- :class:`Wheels`: ``{"vx", "vy", "w"}`` -> ``V±vvvv±vvvv±wwww``, ``"stop"`` -> ``x``,
  refused by name outside the board file's limits before anything is sent;
- :class:`Odometry`: polls ``O`` on its own thread and integrates the flow sensors'
  sums into a pose (esair_min.core.odometry), from the start pose.
"""

from __future__ import annotations

import math
import threading
import time
from typing import TYPE_CHECKING, Callable

from esair_std import Actuator, CommandError
from esair_min.core.odometry import FlowOdometry, parse_odometry
from esair_min.core.protocol import velocity_line

from ..minlink.budget import LineBudget
from ..minlink.commands import VERSION_PREFIX, RobotCommands
from ..minlink.driver import PolledSensor, LinkAgent
from ..minlink.link_errors import LinkError
from ..minlink.link import Exchange, Link
from ..minlink.budget import BITS_PER_BYTE
from .tickclock import TickClock
from ...transport.codec import JSON, JSONObject
from .omniboard import OmniBoard, omni_of
from .scene import wrap

if TYPE_CHECKING:  # pragma: no cover - the model: a test's, or a driver not prepared
    from esair_min.model.robot import Robot

#: the omni base's lines by action (docs/protocol.md, STARFISH)
PREFIX = {"velocity": "V", "odometry": "O", "stop": "x", "version": "v"}
#: the extra poll after a stop, this long after the central board's first tick from
#: when the wheels are at rest by the ramp: the tick whose flow sums the reply carries
#: came after the rest
AT_REST_S = 0.002
#: the longest ``O`` reply: n=65535 and two sensors' -2147483648,-2147483648,255
ODOMETRY_REPLY_BYTES = len("OK n=65535") + 2 * len(" a=-2147483648,-2147483648,255") + 2


class OmniCommands(RobotCommands):
    """The command set of a central board with ``base:`` (it has no command table)."""

    def __init__(self, robot: Robot | OmniBoard):
        omni = omni_of(robot)
        super().__init__(omni.board)
        self.flow = len(omni.flow)
        self.wheels = omni.wheels

    def prefix(self, action: str) -> str:
        try:
            return PREFIX[action]
        except KeyError:
            raise LinkError(f"robot {self.robot.name} (an omni base) has no {action!r} "
                            f"command") from None

    def action_of(self, line: str) -> str | None:
        if line in ("O", "x", "v"):
            return {"O": "odometry", "x": "stop", "v": "version"}[line]
        return "velocity" if line.startswith("V") and len(line) == 16 else None

    def plausible(self, line: str, data: str) -> bool:
        action = self.action_of(line)
        if action == "odometry":
            return data.startswith("n=")
        if action == "version":
            return data.startswith(VERSION_PREFIX)
        return data == ""

    def expected_version(self) -> dict[str, str]:
        return {"wheels": str(self.wheels), "flow": str(self.flow),
                "checksum": "on" if self.checksum else "off"}


def omni_budget(robot: Robot | OmniBoard) -> LineBudget:
    """The line's budget; its "feet" exchange is the odometry poll (``O`` and its longest
    reply), the only poll the omni base has."""
    board = omni_of(robot).board
    checksum = board.checksum
    return LineBudget(baud=board.baud, tick_s=board.tick_s, sensor_read_s=0.0,
                      feet_request_bytes=len("O") + (3 if checksum else 0) + 2,
                      feet_reply_bytes=ODOMETRY_REPLY_BYTES)


class Wheels(LinkAgent, Actuator):
    """The body velocity in the robot's frame: ``{"vx": mm/s, "vy": mm/s, "w": mrad/s}``
    (missing keys 0) or ``"stop"``. With ``robot`` (its model or OmniBoard) and
    ``at_rest`` (a callback): after a stop, ``at_rest(t)`` is told when the wheels are at
    rest at the latest (``time.monotonic()``): the drive board's ramp from the last speeds
    commanded."""

    def __init__(self, link: Link, max_v: int, max_w: int,
                 robot: Robot | OmniBoard | None = None,
                 at_rest: Callable[[float], None] | None = None):
        self.link, self.max_v, self.max_w = link, max_v, max_w
        self.at_rest = at_rest
        self.last = (0, 0, 0)
        omni = None if robot is None else omni_of(robot)
        self._drive = () if omni is None else omni.drive
        self.tick = 0.0 if omni is None else omni.control_tick_s
        # each wheel's rim speed by the drive board's ramp from the commands written (on
        # this computer's clock, from when each was written: at most the board's), when
        # the last was written, and its rim speeds; None: not known (a write that failed)
        self._rims: list[float] | None = [0.0] * len(self._drive)
        self._since = 0.0
        self._targets = [0.0] * len(self._drive)

    def _rims_at(self, t: float) -> list[float] | None:
        if self.tick <= 0:
            return None
        if self._rims is None:
            # not known since a write that failed or a halt; a second after a stop the
            # wheels are at rest whatever they did (the ramp down from the top: 0.3 s)
            if any(self._targets) or t - self._since < 1.0:
                return None
            return [0.0] * len(self._drive)
        out = []
        for v, target, (_, _, _, step) in zip(self._rims, self._targets, self._drive):
            change = step * max(0.0, t - self._since) / self.tick
            out.append(v + max(-change, min(change, target - v)))
        return out

    def _rest_in(self, now: float) -> float:
        """Seconds from a stop's reply to the wheels at rest, at the latest: the drive
        board takes it at its next control tick and ramps each wheel down by its step a
        tick from its speed, the last step a tick after the first. Its speed: the last
        commanded, or less where the ramp from the commands written says so (a short
        turn stopped on its way up), give or take two steps (the board ramps in steps,
        from its tick after each line arrived)."""
        vx, vy, w = self.last
        rims = self._rims_at(now)
        ticks = 0
        for i, (cx, cy, cw, step) in enumerate(self._drive):
            speed = abs(cx * vx + cy * vy + cw * w / 1000)
            if rims is not None:
                speed = min(speed, abs(rims[i]) + 2 * step)
            ticks = max(ticks, math.ceil(speed / max(1.0, step) - 1e-9))
        return ticks * self.tick

    def _written(self, targets: list[float] | None, send: Callable[[], object]) -> None:
        """Write a line (``send``) that sets the wheels' ``targets`` (rim speeds)."""
        now = time.monotonic()
        rims, self._rims = self._rims_at(now), None         # unknown if it fails
        self._since, self._targets = now, list(targets or [1.0])
        send()
        if rims is not None and targets is not None and self.tick > 0:
            self._rims = rims

    def write(self, command: JSON) -> dict[str, int]:
        if command == "stop":
            now = time.monotonic()
            rest_in = self._rest_in(now) if self._drive else 0.0
            self._written([0.0] * len(self._drive), lambda: self._send("x"))
            if self.at_rest is not None and self._drive and any(self.last):
                self.at_rest(time.monotonic() + rest_in)
            self.last = (0, 0, 0)
            return {"vx": 0, "vy": 0, "w": 0}
        if not isinstance(command, dict) or set(command) - {"vx", "vy", "w"}:
            raise CommandError(self.name, f"expected {{'vx': mm/s, 'vy': mm/s, 'w': mrad/s}} or "
                                          f"'stop', got {command!r}")
        out: dict[str, int] = {}
        for key, limit, unit in (("vx", self.max_v, "mm/s"), ("vy", self.max_v, "mm/s"),
                                 ("w", self.max_w, "mrad/s")):
            v = command.get(key, 0)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise CommandError(self.name, f"{key} must be a number, not {v!r}")
            if abs(v) > limit:
                raise CommandError(self.name, f"{key} {v} {unit} is outside the limit "
                                              f"+-{limit} {unit}")
            out[key] = int(round(v))
        targets = [cx * out["vx"] + cy * out["vy"] + cw * out["w"] / 1000
                   for cx, cy, cw, _ in self._drive]
        self._written(targets, lambda: self._send(velocity_line(out["vx"], out["vy"], out["w"])))
        self.last = (out["vx"], out["vy"], out["w"])
        return out

    def halt(self) -> dict[str, int] | None:
        """The latched STOP's ``x`` (the driver's halt() sent it: the wheels to zero),
        recorded as this actuator's ``stop``; None when it could not go."""
        self._rims, self._since = None, time.monotonic()     # the wheels ramp down
        self._targets = [0.0] * len(self._drive)
        return None if self.link.last_stop is None else {"vx": 0, "vy": 0, "w": 0}


class Odometry(PolledSensor[str]):
    """The pose from the flow sensors: ``O`` polled ``hz`` times a second on its own
    thread, the sums integrated from ``start`` (x m, y m, heading rad). ``reset()``
    starts again from ``start`` (a restarted robot's sums begin at 0 where it stands)."""

    thread_name = "starfish-odometry"

    def __init__(self, link: Link, robot: Robot | OmniBoard, hz: float,
                 start: tuple[float, float, float]):
        super().__init__()
        self.link, self.hz, self.start = link, hz, start
        omni = omni_of(robot)
        self.flow = omni.flow
        self._lock = threading.Lock()
        self.bad_replies = 0
        self.clock = TickClock(omni.board.tick_s, BITS_PER_BYTE / omni.board.baud)
        self._k = 0
        self._exchange: Exchange | None = None
        self._poll_at: float | None = None
        self._wake = threading.Event()
        self.reset()

    def dither(self) -> float:
        # each poll a golden-ratio step further into the board's tick: the replies'
        # bounds on its clock (tickclock.py) close in from every phase
        self._k += 1
        return (self._k * 0.6180339887 % 1.0) * self.clock.tick

    def poll_at(self, t: float) -> None:
        """One poll more at ``t`` (``time.monotonic()``; the wheels at rest after a stop:
        the frame that sees the robot stand comes then, not up to a period later): just
        after the central board's first tick from ``t`` where the replies tell its phase
        (tickclock.py), else a whole tick later."""
        tick, clock = self.clock.tick, self.clock
        if clock.low and clock.spread() < 0.25 * tick:
            first = clock.origin() + math.ceil((t - clock.origin()) / tick) * tick
            self._poll_at = first + clock.spread() + AT_REST_S
        else:
            self._poll_at = t + tick + AT_REST_S
        self._wake.set()

    def sleep_until(self, t: float) -> None:
        while not self._stop.is_set():
            now, at = time.monotonic(), self._poll_at
            if at is not None and at <= now:
                self._poll_at = None
                if self.link.up:
                    self._poll()
                continue
            end = t if at is None else min(t, at)
            if end <= now:
                return
            self._wake.wait(end - now)
            self._wake.clear()

    def reset(self) -> None:
        x, y, th = self.start
        with self._lock:
            self.odo = FlowOdometry(self.flow, x * 1000, y * 1000, th)
            self.pose = (x, y, th)
            self.last_n: int | None = None

    def fetch(self) -> str:
        ex = self._exchange = self.link.exchange("O")
        assert ex.data is not None
        return ex.data

    def value(self, data: str) -> JSONObject | None:
        try:
            n, sensors = parse_odometry("OK " + data)
        except (ValueError, IndexError):
            self.bad_replies += 1
            return None
        with self._lock:
            before = self.pose
            x, y, th = self.odo.update([(dx, dy) for dx, dy, _ in sensors])
            self.pose = (x / 1000, y / 1000, th)
            self.last_n = n
        moving = math.hypot(self.pose[0] - before[0], self.pose[1] - before[1]) > 1e-4 or \
            abs(self.pose[2] - before[2]) > 1e-4
        out: JSONObject = {"x": round(self.pose[0], 4), "y": round(self.pose[1], 4),
                           "th": round(wrap(self.pose[2]), 5), "moving": moving,
                           "squal": [q for _, _, q in sensors], "n": n}
        ex = self._exchange
        if ex is not None and ex.t_reply:
            # when the board read these sums (tick n), on this computer's clock
            tn = self.clock.add(n, ex.t_sent, ex.sent_bytes, ex.t_reply, len(data) + 5)
            out["tn"] = round(tn + time.time() - time.monotonic(), 5)
            out["tn_spread"] = round(self.clock.spread(), 5)
        return out
