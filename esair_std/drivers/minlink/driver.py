"""``MinLink``: one MIN robot as ESAIR STD resources (docs/std-papaman.md).

Deployment entry (the entry's name is the robot's name in resource names)::

    papaman:
      class: esair_std.drivers.minlink:MinLink
      robot: papaman              # board files: a folder, a file, or a bundled example
      port: /dev/ttyUSB0          # anything pySerial opens: device, pty, esair:// URL,
                                  # or "emulate": the driver starts `esair emulate ROBOT
                                  # --pty` as its child process and uses its pty
      emulate: {scenario: push, trace: t.txt, noise: 5,   # that child's options, and
                restart: {max: 3, within: 60}}      # its restart policy (default none)
      feet_hz: 8                  # `s` polls per second (refused beyond the line budget;
                                  # 0: not polled)
      feet_share: 0.5             # the share of the line the polls may use
      timeout: 1.0                # seconds for a reply; longer means the link is down
                                  # (default 1, or 3 for port: emulate: the emulator
                                  # shares this computer's cores, a board does not)
      deadline: 0.5               # seconds from a command's arrival to its line written;
                                  # later it is dropped, never sent (CommandError)
      duplex: true                # write a command while a reply arrives (false: one
                                  # command in flight; docs/std-papaman.md, "Full duplex")
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
  auto_balance``, ``H auto_balance`` while held, ``E10 no answer on i2c``, ``READY ...``).

The runtime's latched STOP (docs/std.md) holds the link (``halt()``): ``x`` goes at
once, ahead of every command, then ``h1`` holds the firmware's own reactions (a tip
sends ``!H`` and moves nothing), and nothing but those and the polls goes until the
release, which sends ``h0``; a STOP made while the link is down is written first thing
(``x`` then ``h1``) when it is back; a reaction's ``!R`` while held is answered with
``x`` at once.

An ``Enn`` reply reaches the sender as ``CommandError(resource, "robot refused 'LINE':
Enn text")``. While the link is down every resource is ``lost`` (``esair std ls`` shows
the reason) and commands fail at once with ``ResourceLost``; they are ``ready`` again
when the link is back, on the same robot only: another robot answering on the port
(another ``id=`` in its ``v`` reply) leaves them ``lost: a different robot answers on
PORT (id X, expected Y)``.

Deadlines: a command is written within ``deadline`` of its arrival and within the
sender's ``send(..., timeout=T)``, whichever ends first, or it is dropped and the sender
gets ``CommandError(resource, "link to PORT: 'LINE' not written within its deadline;
dropped")``; one that arrived before the link last came back is dropped too ("... was
asked before the link came back ..."). Nothing asked before a reconnect is written after.

With ``port: emulate`` the driver owns the emulated robot: when it exits by itself the
resources are ``lost: emulator exited (status N)`` (N as Python reports it: -9 is
SIGKILL), the port is never opened again while no child runs, and the child is reaped at
once (no zombie). ``emulate: {restart: {max: N, within: T}}`` restarts it, at most N
times within T seconds, as behaviors' policy; the link takes back only its own child
(the same ``--instance``).
"""

from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any, Generic, TypeVar

from esair_std import Actuator, CommandError, Driver, ResourceLost, Sensor

from esair_min.errors import EsairError

from ...restart_window import RestartWindow
from ...errors import DeployError
from .board import Board, board_of
from .budget import DEFAULT_DEADLINE_S, DEFAULT_FEET_SHARE, line_budget
from .emulated import EmulatedRobot
from .link_errors import LinkDown, LinkError
from .link import DIFFERENT_ROBOT, Exchange, Link
from ...transport.codec import JSON, JSONObject

if TYPE_CHECKING:  # pragma: no cover - the schema is imported only to check options
    from pydantic import BaseModel

_R = TypeVar("_R", bound=JSON)     # what one poll of a PolledSensor gets


class LinkAgent(Actuator):
    """What the actuators over the link share: send a line, map the link's errors."""

    link: Link
    deadline_s: float = DEFAULT_DEADLINE_S

    def _send(self, line: str) -> str:
        self._exchange(line)
        return line

    def _exchange(self, line: str) -> Exchange:
        # the resource host says when the command arrived and when its sender gives up
        asked = getattr(self._esair, "asked", None)
        expires = getattr(self._esair, "expires", None)
        deadline = (time.monotonic() if asked is None else asked) + self.deadline_s
        if expires is not None:
            deadline = min(deadline, expires)
        try:
            return self.link.exchange(line, deadline=deadline, asked=asked)
        except LinkDown as exc:
            raise ResourceLost(self.name, str(exc)) from None
        except LinkError as exc:
            raise CommandError(self.name, str(exc)) from None


class ServoActuator(LinkAgent, Actuator):
    def __init__(self, link: Link, servo: str):
        self.link, self.servo = link, servo

    def write(self, command: JSON) -> str:
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


class MotionActuator(LinkAgent, Actuator):
    def __init__(self, link: Link):
        self.link = link

    def write(self, command: JSON) -> str | JSONObject:
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
        if command in ("stand", {"stand": True}):
            return self._send(line)
        return self._took(self._exchange(line))

    def _took(self, ex: Exchange) -> JSONObject:
        # a play and a stop say when the robot had the whole line (written, then its
        # bytes' time on the wire): the motion starts or stops then, while the reply may
        # come later (behind a feet reply on its way, full duplex); the HMI shows the
        # frame a motion reached from these times (docs/hmi.md)
        took = ex.t_sent + self.link.budget.line_s(ex.sent_bytes)
        return {"line": ex.line, "at": round(time.time() - (time.monotonic() - took), 4)}

    def halt(self) -> JSONObject | None:
        """The latched STOP's ``x`` (the driver's halt() sent it): recorded as this
        actuator's ``stop``, with when the robot had it; None when it could not go."""
        ex = self.link.last_stop
        return None if ex is None else self._took(ex)


class PolledSensor(Sensor, Generic[_R]):
    """A sensor polled over the link on its own thread, ``hz`` times a second while the
    link is up (the host does not poll it: ``rate_hz`` stays None; 0: not polled). A
    poll the robot refuses marks it lost, the next good one ready again; a link down is
    the driver's to report. Subclasses say how to poll (:meth:`fetch`) and what a reply
    reports (:meth:`value`)."""

    link: Link
    hz: float
    thread_name = "minlink-poll"

    def __init__(self) -> None:
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._fault = False
        self.polls = 0

    def fetch(self) -> _R:
        """One poll's reply (raises the link's errors)."""
        raise NotImplementedError

    def value(self, reply: _R) -> JSON:
        """The sample ``reply`` reports, or None: nothing to report (a bad reply)."""
        return reply

    def open(self) -> None:
        if not self.hz:
            return
        self._thread = threading.Thread(target=self._run, name=f"{self.thread_name}:{self.name}",
                                        daemon=True)
        self._thread.start()

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)

    def dither(self) -> float:
        """Seconds (>= 0) the next poll waits beyond its turn; none by default."""
        return 0.0

    def _run(self) -> None:
        next_t = time.monotonic()
        while not self._stop.is_set():
            if self.link.up:
                self._poll()
            next_t += 1.0 / self.hz
            now = time.monotonic()
            if next_t < now:                       # late (a long command): start afresh
                next_t = now
            self.sleep_until(next_t + self.dither())

    def sleep_until(self, t: float) -> None:
        """Wait until ``t`` (``time.monotonic()``) or the sensor closes."""
        self._stop.wait(t - time.monotonic())

    def _poll(self) -> None:
        try:
            reply = self.fetch()
        except LinkDown:
            return                                  # the driver marks every resource lost
        except LinkError as exc:
            self._fault = True
            self.mark_lost(str(exc))
            return
        value = self.value(reply)
        if value is None:
            return
        self.polls += 1
        if self._fault:
            self._fault = False
            self.mark_ready()
        self.report(value)


class FeetSensor(PolledSensor[JSONObject]):
    """Polls ``s`` (a poll: commands go first)."""

    thread_name = "minlink-feet"
    settings = ("rate_hz", "feet_hz")       # the same: the polls per second

    def __init__(self, link: Link, hz: float, share: float):
        super().__init__()
        self.link, self.hz, self.share = link, hz, share

    def fetch(self) -> JSONObject:
        return self.link.feet(poll=True)

    def configure(self, key: str, value: JSON) -> float:
        if key in ("rate_hz", "feet_hz"):
            try:
                hz = float(value)       # type: ignore[arg-type]  # no number: TypeError, refused
                self.link.budget.check_feet_hz(hz, self.share)
            except (TypeError, ValueError, LinkError) as exc:
                raise CommandError(self.name, str(exc)) from None
            if not self.hz and hz:
                self.hz = hz
                self.open()
            self.hz = hz
            return hz
        raise self.no_setting(key)


class NoticeSensor(Sensor):
    """The robot's ``!`` lines, reported as they come (from the link's I/O thread: a
    report only copies the sample into the subscribers' bounded mailboxes)."""

    def notice(self, text: str, t: float) -> None:
        if self._esair is not None:
            self.report({"notice": text})


#: ``emulate:`` options that name a file: relative to the deployment file's folder (a
#: scenario only when such a file exists there; else it is a name in ROBOT/scenarios/).
PATH_OPTIONS = ("trace", "generate", "scenario")


def emulate_args(opts: dict[str, object], base: Path | None = None) -> list[str]:
    """``esair emulate`` arguments from the ``emulate:`` option of the entry (relative
    paths taken from ``base``, the deployment file's folder)."""
    if not isinstance(opts, dict):
        raise LinkError(f"option 'emulate' must be a mapping, got {opts!r}")
    args: list[str] = []
    for key, value in opts.items():
        if key == "restart":                # the driver's policy, not the child's
            continue
        flag = "--" + str(key).replace("_", "-")
        if value is True:
            args.append(flag)
        elif value not in (False, None):
            if base is not None and key in PATH_OPTIONS and isinstance(value, str):
                value = in_folder(base, value, must_exist=key == "scenario")
            args += [flag, str(value)]
    return args


def in_folder(base: Path, value: str, must_exist: bool = False) -> str:
    """``value`` relative to ``base`` when it is a relative path (and, ``must_exist``,
    a file is there)."""
    p = Path(value)
    if p.is_absolute() or (must_exist and not (base / p).exists()):
        return value
    return str(base / p)


#: The reply timeout of an emulated robot (``port: emulate``) when the entry names none:
#: the emulator shares the host's cores, so on a busy computer its replies can come later
#: than a real board's ever would; 1 s for any other port.
EMULATED_TIMEOUT_S = 3.0


class _Options:
    """A ``MinLink`` entry's options, checked (options.py's ``MinLinkOptions``, dumped
    to plain values): what :meth:`MinLink.open` reads of them."""

    def __init__(self, d: dict[str, Any]):
        self.robot: str | None = d.get("robot")
        self.port: str = str(d["port"])
        emulate = dict(d.get("emulate") or {})
        restart = dict(emulate.pop("restart", None) or {})
        self.restart_max = int(restart.get("max", 0))
        self.restart_within = float(restart.get("within", 0.0))
        self.emulate: dict[str, object] = emulate        # the child's options
        self.feet_hz = float(d.get("feet_hz", 8.0))
        self.feet_share = float(d.get("feet_share", DEFAULT_FEET_SHARE))
        timeout = d.get("timeout")
        self.timeout = float(timeout if timeout is not None else
                             EMULATED_TIMEOUT_S if self.port == "emulate" else 1.0)
        self.deadline = float(d.get("deadline", DEFAULT_DEADLINE_S))
        self.duplex = bool(d.get("duplex", True))


class MinLink(Driver):
    """One MIN robot over its serial link (see the module docstring)."""

    #: the entry's options (checked with the deployment, each error at its line): named,
    #: not imported, so that a robot side handed them checked never loads pydantic
    Options: type[BaseModel] | str = "esair_std.drivers.minlink.options:MinLinkOptions"

    @classmethod
    def prepare_entry(cls, options: dict[str, object], base_dir: str | Path | None,
                      name: str) -> JSONObject | None:
        """What :meth:`open` needs, as plain JSON: the options checked, the board files'
        path and what the link uses of their model (:mod:`.board`), and the files read
        (``inputs``). ``esair std run`` calls it where the deployment is checked (not in
        the robot side's process, which then imports neither pydantic nor the model);
        ``open`` calls it when it was not (an entry added at run time, the Python API)."""
        from ...deploy.class_options import check_options
        from .options import MinLinkOptions
        try:
            o = check_options(MinLinkOptions, dict(options))
        except DeployError as exc:      # an entry added at run time: its options' paths
            raise LinkError(f"{name}: {exc}") from None
        assert isinstance(o, MinLinkOptions)
        base = Path(base_dir or ".")                      # the deployment file's folder
        robot_arg = o.robot if o.robot is not None else name
        robot_arg = in_folder(base, robot_arg, must_exist=True)
        from esair_min.model.validate import board_files, load_robot
        from esair_min.resources import resolve_robot
        try:
            path = resolve_robot(str(robot_arg))
            robot = load_robot(path)
        except EsairError as exc:
            raise LinkError(f"{name}: robot {robot_arg!r}: {exc}") from None
        return {"options": o.model_dump(mode="json"), "path": str(path),
                "board": board_of(robot).to_json(),
                "inputs": [str(f) for f in board_files(path)]}

    def open(self) -> None:
        spec = self._esair.spec
        base = Path(getattr(spec, "base_dir", None) or ".")    # the file's folder
        prepared: Any = getattr(spec, "prepared", None)
        if not prepared or "board" not in prepared:      # not prepared beforehand
            prepared = self.prepare_entry(dict(self.options), base, self.name)
        o = _Options(prepared["options"])
        path = Path(str(prepared["path"]))
        robot = Board.from_json(prepared["board"])
        port = o.port
        self.children: dict[str, Sensor | Actuator] = {}
        self.emulated: EmulatedRobot | None = None
        hz, share, timeout, deadline = o.feet_hz, o.feet_share, o.timeout, o.deadline
        duplex = o.duplex
        if hz != 0:                                         # 0: the feet are not polled
            line_budget(robot).check_feet_hz(hz, share)    # refused before anything starts
        self._closing = threading.Event()
        self._lost: str | None = None        # the emulator's exit, while it is not back
        self._supervisor: threading.Thread | None = None
        expect = None
        if port == "emulate":
            self._restarts = RestartWindow(o.restart_max, o.restart_within)
            self.emulated = EmulatedRobot(path, emulate_args(o.emulate, base))
            expect = self.emulated.instance
            port = self.emulated.start()
        self.notices = NoticeSensor()
        self.link = Link(robot, str(port), timeout=timeout,
                         on_state=self._link_state, on_notice=self.notices.notice,
                         expect_id=expect, duplex=duplex,
                         may_open=self.emulated.held if self.emulated is not None else None)
        try:
            self.link.open()
        except BaseException:
            if self.emulated is not None:
                self.emulated.stop()
            raise
        kids: dict[str, Sensor | Actuator] = {
            f"servo.{s.name}": ServoActuator(self.link, s.name) for s in robot.servos}
        kids["motion"] = MotionActuator(self.link)
        kids["feet"] = FeetSensor(self.link, hz, share)
        kids["notices"] = self.notices
        for kid in kids.values():
            if isinstance(kid, LinkAgent):
                kid.deadline_s = deadline
        self.children = kids
        if self.emulated is not None:
            self._supervisor = threading.Thread(target=self._supervise, daemon=True,
                                                name=f"minlink-emulator:{self.name}")
            self._supervisor.start()

    def resources(self) -> dict[str, Sensor | Actuator]:
        return self.children

    def halt(self) -> None:
        """The runtime's latched STOP: the link sends ``x`` ahead of everything and
        ``h1`` (the firmware's reactions held), then refuses every line but those and
        the polls; while down, it sends them first thing when it comes back (link.py,
        "Held")."""
        self.link.hold(True)

    def release(self) -> None:
        self.link.hold(False)

    def close(self) -> None:
        link, emulated = getattr(self, "link", None), getattr(self, "emulated", None)
        closing = getattr(self, "_closing", None)
        if closing is not None:
            closing.set()
        if link is not None:               # open() may have failed before either existed
            link.close()
        if emulated is not None:
            emulated.stop()                # wakes the supervisor, which then ends
        sup = getattr(self, "_supervisor", None)
        if sup is not None and sup is not threading.current_thread():
            sup.join(timeout=10)

    def _link_state(self, up: bool, reason: str) -> None:
        if up:
            self._lost = None
        elif self._lost is not None:       # the emulator's exit says more than the port
            reason = self._lost
        elif not reason.startswith(DIFFERENT_ROBOT):
            reason = f"link down: {reason}"
        self._mark(up, reason)

    def _mark(self, up: bool, reason: str) -> None:
        for child in self.children.values():
            if getattr(child, "_esair", None) is None:
                continue
            if up:
                child.mark_ready()
            else:
                child.mark_lost(reason)

    # -- the emulated robot ------------------------------------------------------------
    def _supervise(self) -> None:
        """Reap the emulated robot when it exits by itself, mark the resources lost with
        its status, restart it under the policy. Children started here get SIGTERM if
        this thread ends first: it lives until close()."""
        emulated = self.emulated
        assert emulated is not None
        while not self._closing.is_set():
            code = emulated.wait_exit()
            if code is None or self._closing.is_set():
                return                     # stopped on purpose
            reason = f"emulator exited (status {code})"
            self._lost = reason
            self._mark(False, reason)
            window = self._restarts
            if not window.allow(time.monotonic()):
                if window.max:
                    self._lost = (f"{reason}; not restarted: {window.max} restart(s) within "
                                  f"{window.within:g} s already")
                    self._mark(False, self._lost)
                return
            try:
                emulated.start()
            except LinkError as exc:
                self._lost = f"{reason}; its restart failed: {exc}"
                self._mark(False, self._lost)
                return
