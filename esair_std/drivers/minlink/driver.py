"""``MinLink``: one MIN robot as ESAIR STD resources (docs/std-papaman.md).

Deployment entry (the entry's name is the robot's name in resource names)::

    papaman:
      class: esair_std.drivers.minlink:MinLink
      robot: papaman              # board files: a folder, a file, or a bundled example
      port: /dev/ttyUSB0          # anything pySerial opens: device, pty, esair:// URL,
                                  # or "emulate": the driver starts `esair emulate ROBOT
                                  # --pty` as its child process and uses its pty
      emulate: {scenario: push, trace: t.txt, noise: 5}   # that child's options
      feet_hz: 8                  # `s` polls per second (refused beyond the line budget;
                                  # 0: not polled)
      feet_share: 0.5             # the share of the line the polls may use
      timeout: 1.0                # seconds for a reply; longer means the link is down
      allow: {"*": command}

Resources, named from the board files:

- ``<entry>.servo.<servo>`` actuator: ``{"angle": A, "speed": S}`` (or just ``A``; the
  speed defaults to the servo's ``default_speed``) -> ``oMSAAA``, the angle checked
  against the servo's limits before sending; returns the line sent;
- ``<entry>.motion`` actuator: ``{"play": n|name}`` -> ``PLYnn``, ``"stand"`` -> ``t``,
  ``"stop"`` -> ``x``; returns the line sent;
- ``<entry>.feet`` sensor: the ``s`` reply, ``{"values": {sensor: n}, "groups": {group:
  sum}}``, polled ``feet_hz`` times a second by the driver's own poller (so that a
  refused poll marks it lost and the next good one ready again);
- ``<entry>.notices`` sensor: every ``!`` line as ``{"notice": text}`` (``R
  auto_balance``, ``E10 no answer on i2c``, ``READY ...``).

An ``Enn`` reply reaches the sender as ``CommandError(resource, "robot refused 'LINE':
Enn text")``. While the link is down every resource is ``lost`` (``esair std ls`` shows
the reason) and commands fail at once with ``ResourceLost``; they are ``ready`` again
when the link is back.
"""

from __future__ import annotations

import threading
import time
from typing import Any

from esair_std import Actuator, CommandError, Driver, ResourceLost, Sensor

from esair_min.errors import EsairError
from esair_min.model.validate import load_robot
from esair_min.resources import resolve_robot

from .budget import DEFAULT_FEET_SHARE, line_budget
from .emulated import EmulatedRobot
from .errors import LinkDown, LinkError
from .link import Link

DEFAULT_FEET_HZ = 8.0


class _LinkAgent:
    """What servo, motion and feet share: send a line, map the link's errors."""

    link: Link
    _esair: Any

    def _send(self, line: str) -> str:
        try:
            self.link.command(line)
        except LinkDown as exc:
            raise ResourceLost(self.name, str(exc)) from None     # type: ignore[attr-defined]
        except LinkError as exc:
            raise CommandError(self.name, str(exc)) from None     # type: ignore[attr-defined]
        return line


class ServoActuator(_LinkAgent, Actuator):
    def __init__(self, link: Link, servo: str):
        self.link, self.servo = link, servo

    def write(self, command: Any) -> Any:
        if isinstance(command, dict):
            unknown = set(command) - {"angle", "speed"}
            if unknown or "angle" not in command:
                raise CommandError(self.name, f"expected {{'angle': A, 'speed': S}}, got "
                                              f"{command!r}")
            angle, speed = command["angle"], command.get("speed")
        else:
            angle, speed = command, None
        try:
            line = self.link.commands.motor(self.servo, angle, speed)
        except LinkError as exc:
            raise CommandError(self.name, str(exc)) from None
        return self._send(line)


class MotionActuator(_LinkAgent, Actuator):
    def __init__(self, link: Link):
        self.link = link

    def write(self, command: Any) -> Any:
        cmds = self.link.commands
        try:
            if command in ("stand", {"stand": True}):
                line = cmds.prefix("stand")
            elif command in ("stop", {"stop": True}):
                line = cmds.prefix("stop")
            elif isinstance(command, dict) and set(command) == {"play"}:
                line = cmds.play(command["play"])
            else:
                raise LinkError(f"expected 'stand', 'stop' or {{'play': n or name}}, got "
                                f"{command!r}")
        except LinkError as exc:
            raise CommandError(self.name, str(exc)) from None
        return self._send(line)


class FeetSensor(Sensor):
    """Polls ``s`` on its own thread (the host does not poll it: ``rate_hz`` stays None)."""

    def __init__(self, link: Link, hz: float, share: float):
        self.link, self.hz, self.share = link, hz, share
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._fault = False
        self.polls = 0

    def open(self) -> None:
        if not self.hz:
            return
        self._thread = threading.Thread(target=self._run, name=f"minlink-feet:{self.name}",
                                        daemon=True)
        self._thread.start()

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)

    def configure(self, key: str, value: Any) -> Any:
        if key in ("rate_hz", "feet_hz"):
            try:
                hz = float(value)
                self.link.budget.check_feet_hz(hz, self.share)
            except (TypeError, ValueError, LinkError) as exc:
                raise CommandError(self.name, str(exc)) from None
            if not self.hz and hz:
                self.hz = hz
                self.open()
            self.hz = hz
            return hz
        raise CommandError(self.name, f"no setting {key!r} (settings: rate_hz)")

    def _run(self) -> None:
        next_t = time.monotonic()
        while not self._stop.is_set():
            if self.link.up:
                self._poll()
            next_t += 1.0 / self.hz
            now = time.monotonic()
            if next_t < now:                       # late (a long command): start afresh
                next_t = now
            self._stop.wait(next_t - now)

    def _poll(self) -> None:
        try:
            value = self.link.feet()
        except LinkDown:
            return                                  # the driver marks every resource lost
        except LinkError as exc:
            self._fault = True
            self.mark_lost(str(exc))
            return
        self.polls += 1
        if self._fault:
            self._fault = False
            self.mark_ready()
        self.report(value)


class NoticeSensor(Sensor):
    """The robot's ``!`` lines, reported as they come (from the link's I/O thread: a
    report only copies the sample into the subscribers' bounded mailboxes)."""

    def notice(self, text: str, t: float) -> None:
        if self._esair is not None:
            self.report({"notice": text})


def _number(opts: dict, key: str, default: float) -> float:
    value = opts.get(key, default)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise LinkError(f"option {key!r} must be a number, got {value!r}")
    return float(value)


def emulate_args(opts: dict) -> list[str]:
    """``esair emulate`` arguments from the ``emulate:`` option of the entry."""
    if not isinstance(opts, dict):
        raise LinkError(f"option 'emulate' must be a mapping, got {opts!r}")
    args: list[str] = []
    for key, value in opts.items():
        flag = "--" + str(key).replace("_", "-")
        if value is True:
            args.append(flag)
        elif value not in (False, None):
            args += [flag, str(value)]
    return args


class MinLink(Driver):
    """One MIN robot over its serial link (see the module docstring)."""

    def open(self) -> None:
        opts = dict(self.options)
        robot_arg = opts.get("robot", self.name)
        port = opts.get("port")
        if not port:
            raise LinkError(f"{self.name}: option 'port' is missing (a serial device, a pty, "
                            f"an esair:// URL or 'emulate')")
        try:
            path = resolve_robot(str(robot_arg))
            robot = load_robot(path)
        except EsairError as exc:
            raise LinkError(f"{self.name}: robot {robot_arg!r}: {exc}") from None
        self.children: dict[str, Any] = {}
        self.emulated: EmulatedRobot | None = None
        hz = _number(opts, "feet_hz", DEFAULT_FEET_HZ)
        share = _number(opts, "feet_share", DEFAULT_FEET_SHARE)
        timeout = _number(opts, "timeout", 1.0)
        if hz != 0:                                         # 0: the feet are not polled
            line_budget(robot).check_feet_hz(hz, share)    # refused before anything starts
        if port == "emulate":
            self.emulated = EmulatedRobot(path, emulate_args(opts.get("emulate") or {}))
            port = self.emulated.start()
        self.notices = NoticeSensor()
        self.link = Link(robot, str(port), timeout=timeout,
                         on_state=self._link_state, on_notice=self.notices.notice)
        try:
            self.link.open()
        except BaseException:
            if self.emulated is not None:
                self.emulated.stop()
            raise
        kids: dict[str, Any] = {
            f"servo.{s.name}": ServoActuator(self.link, s.name) for s in robot.servos}
        kids["motion"] = MotionActuator(self.link)
        kids["feet"] = FeetSensor(self.link, hz, share)
        kids["notices"] = self.notices
        self.children = kids

    def resources(self) -> dict[str, Any]:
        return self.children

    def close(self) -> None:
        link, emulated = getattr(self, "link", None), getattr(self, "emulated", None)
        if link is not None:               # open() may have failed before either existed
            link.close()
        if emulated is not None:
            emulated.stop()

    def _link_state(self, up: bool, reason: str) -> None:
        for child in self.children.values():
            if getattr(child, "_esair", None) is None:
                continue
            if up:
                child.mark_ready()
            else:
                child.mark_lost(f"link down: {reason}")
