"""One MIN robot's serial link: full duplex, replies matched in order, notices apart.

An I/O thread reads the port (pySerial: a device, a pty, an ``esair://`` URL). A caller
of :meth:`Link.command` whose command may go out now writes its line itself (no hand-off
to another thread before the bytes leave, which cost 0.05-0.15 ms a command); otherwise
it waits in a queue (bounded), and the I/O thread writes the next queued line the moment
it may go, so the line never idles while commands wait (one writer at a time, as
pySerial's ports allow; lines leave in the order they were taken). Each caller then
waits for the I/O thread to see the line that answers its command; ``!`` lines go to the
notices stream (bounded; what overflows is counted). An ``Enn`` reply raises
:class:`RobotRefused` in the caller, naming the command and the code.

**Full duplex.** The robot answers every line, in order (docs/protocol.md, "Replies"),
and its receive ring takes the next line while a reply is still going out (its transmit
ring is fed by an interrupt). So the link may write a second command while the reply to
the first is arriving (``duplex``, the default; ``duplex=False`` keeps one in flight):
at most two in flight, the second written only

- once the robot is seen answering: a reply line has begun to arrive after the first
  command was written (a robot that hangs gets nothing more: the command waits, and is
  dropped at its deadline);
- when the two replies cannot pass for one another (one ``s``, one ``v``, or one bare
  ``OK`` command: never two of a kind), so an ``OK`` is matched by its shape;
- when the unanswered bytes fit the robot's 64-byte receive ring (it cannot overrun).

**Priority.** Commands go before polls (``poll=True``, the feet sensor's ``s``): a queued
command is written first, whatever polls wait.

The protocol's replies carry no sequence number, so the link keeps them matched by
their order and shape, and resynchronises whenever it cannot be sure:

- an ``OK`` whose shape cannot answer the oldest command in flight (a ``v`` reply to
  ``s``...) is a stray, counted, not a reply;
- an error that only a damaged line can cause (E01 E02 E03 E06 E12 E13: the link only
  sends well-formed lines) may be the answer to a line that noise made up, so the link
  waits ``settle_s`` for a later, plausible ``OK`` before it reports the error; with a
  second command in flight, an ``OK`` of the second's shape in that time says the error
  was the first one's (its reply came first), and a further wire error is the second
  one's candidate error in turn; an error a well-formed line gets (E04, E10...) in that
  time could answer either: the link cannot tell, and goes down (below);
- no reply within ``timeout``, or a port error: the link is **down**. The commands in
  flight fail with :class:`LinkDown`, the port is closed, and the I/O thread reopens
  it with exponential backoff, at once when the port's file is made anew (plugged
  in); it is up again once a ``v`` probe is answered by the robot
  of the board files (servo and sensor count, checksum setting). While down, commands
  fail at once with :class:`LinkDown`; ``on_state`` reports every change.

The robot must be the same one after every reconnect: once the link knows the robot's
``id=`` (docs/protocol.md, "Robot id"; from ``expect_id``, or the first connect, where
a robot without one is known as such) a reconnect to a robot of another id is refused
(:class:`DifferentRobot`, reported by ``on_state``), the port closed again at once: the
only line it got was the read-only ``v`` probe. ``may_open`` (if given) is asked
before each reconnect; a reason from it keeps the port closed (the driver's emulated
robot that exited: its pty may belong to another program by now).

**Held** (:meth:`hold`, the runtime's latched STOP): the stop line (``x``) goes at
once, ahead of every command waiting, which fails with :class:`Held`, as does every
line but the stop, the version and the polls (sensors keep flowing) until
``hold(False)``. Right after the stop line the firmware's own reactions are held too
(``h1``, where the command table has the ``hold`` verb: a reaction that fires then sends
``!H`` and moves nothing, docs/protocol.md); no poll goes between the two. While held,
each (re)connect writes the stop line and ``h1`` before any other byte (a STOP made
while the link was down, or a robot reset since, which releases its reactions, is told
first thing). ``hold(False)``
sends ``h0``; one that could not go is sent at the next connect. A reaction's ``!R``
while held (one that fired before ``h1`` arrived, or a robot without the verb), and a
robot's ``!READY`` (a reset, which releases its reactions, while the port stayed open)
are answered with the stop line and ``h1`` at once (docs/std-papaman.md).

Deadlines: a command carries one (``deadline``, a ``time.monotonic()``; by default its
``timeout`` from the call). A command not written by then fails with :class:`Expired`
and is dropped, never sent; so does one ``asked`` before the link last came up.

:meth:`close` stops and joins the I/O thread and closes the port.
"""

from __future__ import annotations

import collections
import os
import select
import threading
import time
from typing import TYPE_CHECKING, Callable

from esair_min.errors import ProtocolError
from esair_min.core.protocol import RX_RING, Code, parse_reply
from esair_min.serialport import LOCKED, PtyIdentity, describe, open_port, pty_identity, stale_pty

from ...counters import Counters
from .board import Board
from .budget import LineBudget, line_budget
from .commands import VERSION_PREFIX, RobotCommands
from .link_errors import (DifferentRobot, Expired, Held, LinkDown, LinkError, PtyGone,
                          RobotRefused)

if TYPE_CHECKING:  # pragma: no cover - the model is loaded by whoever opens a link
    from esair_min.model.robot import Robot
    from serial import Serial           # pySerial is imported when a port opens

    from ...transport.codec import JSONObject

#: Reply codes a well-formed line cannot get: the line was damaged on the wire.
WIRE_CODES = frozenset({Code.UNKNOWN, Code.TOO_LONG, Code.BAD_ARGUMENT, Code.BAD_CHECKSUM,
                        Code.OVERRUN, Code.BAD_CHARACTER})
MAX_LINE_BYTES = 256        # a longer line from the robot is garbage: dropped, counted
POLL_S = 0.05               # the I/O thread's longest wait on a port it can wake
POLL_S_NO_CANCEL = 0.002    # ... on a port without cancel_read
IDLE_LOOK_S = 1.0           # a port with a descriptor: the longest sleep with nothing due
DUE_SLACK_S = 0.001         # a reply's deadline is looked at just after it passes
GATHER_BYTES = 4            # a line longer than its kind's last: waited for this many more
RESYNC = b"\r\n"            # an empty line: no reply, but it ends a line noise began
RESYNC_IDLE_S = 0.25        # a command after this long a silence is sent after RESYNC
QUEUE_MAX = 64              # commands waiting for their turn; more are refused, not sent
MAX_IN_FLIGHT = 2           # full duplex: one reply arriving, the next command written
DIFFERENT_ROBOT = "a different robot answers on"
OUT_OF_STEP = "replies out of step"
PORT_LOOK_S = 0.05          # while down: how often the port's file is looked at (made anew?)
LOCK_WAIT_S = 3.0           # a port another program holds is tried again this long: a link
                            # reconnecting to a pty number that is now this robot's holds
                            # it for its probe (a `v` or two), then lets go


class Exchange:
    """One command and its fate. Times are ``time.monotonic()``. (A plain class, not a
    dataclass: ``dataclasses`` imports ``inspect`` and ``ast`` into the robot side.)"""

    __slots__ = ("line", "wire", "timeout", "deadline", "poll", "kind", "sent", "t_sent",
                 "t_reply", "sent_bytes", "data", "error", "settle_until", "first_error",
                 "later_error", "started", "done")

    def __init__(self, line: str, wire: bytes, timeout: float,
                 deadline: float = float("inf"), poll: bool = False, kind: str = ""):
        self.line, self.wire, self.timeout = line, wire, timeout
        self.deadline = deadline          # not written by then: Expired, dropped
        self.poll = poll                  # a poll: commands go first
        self.kind = kind                  # the shape of its OK reply (never two alike in flight)
        self.sent = False
        self.t_sent = 0.0
        self.t_reply = 0.0
        self.sent_bytes = 0
        self.data: str | None = None
        self.error: LinkError | None = None
        self.settle_until: float | None = None
        self.first_error: RobotRefused | None = None
        self.later_error: RobotRefused | None = None    # a wire error after first_error
        self.started = threading.Event()  # its turn came
        self.done = threading.Event()

    def __repr__(self) -> str:
        return (f"Exchange(line={self.line!r}, sent={self.sent}, data={self.data!r}, "
                f"error={self.error!r})")


StateCallback = Callable[[bool, str], None]
NoticeCallback = Callable[[str, float], None]
_Start = tuple[Exchange, "Serial", bytes]


class Link:
    """The serial link to one MIN robot (see the module docstring)."""

    def __init__(self, robot: Board | Robot, port: str, *, baud: int | None = None,
                 timeout: float = 1.0, backoff: tuple[float, float] = (0.05, 2.0),
                 notice_capacity: int = 256, on_state: StateCallback | None = None,
                 on_notice: NoticeCallback | None = None, expect_id: str | None = None,
                 may_open: Callable[[], str | None] | None = None, duplex: bool = True,
                 commands: RobotCommands | None = None, budget: LineBudget | None = None):
        if not timeout > 0:
            raise LinkError(f"link timeout {timeout:g} s must be more than 0")
        self.robot = robot
        self.port = port
        # another command set (STARFISH's omni base) brings its own lines and budget
        self.commands = RobotCommands(robot) if commands is None else commands
        self.budget = line_budget(robot) if budget is None else budget
        self.baud = baud or self.budget.baud
        self.timeout = timeout
        self.backoff = backoff
        self.duplex = duplex
        self.max_in_flight = MAX_IN_FLIGHT if duplex else 1
        self.settle_s = (self.budget.line_s(2 * 44) + 2 * self.budget.tick_s)
        self.on_state = on_state
        self.on_notice = on_notice
        self.robot_id = expect_id          # the robot's id= (None: it answers none)
        self._known = expect_id is not None  # else learnt at the first connect
        self.may_open = may_open
        self._pty: PtyIdentity | None = None   # the pty the port led to at the last connect
        self.up_since = 0.0                # time.monotonic() of the last connect
        self.stats = Counters()             # the I/O thread and callers count
        self._notices: collections.deque[tuple[str, float]] = collections.deque(
            maxlen=notice_capacity)
        # _lock guards _flight, _queue, _polls, _port, _up, _reason; _write_lock: one
        # writer at a time, taken while _lock is held so lines leave in the order taken
        self._lock = threading.Lock()
        self._write_lock = threading.Lock()
        self._flight: collections.deque[Exchange] = collections.deque()  # oldest first
        self._queue: collections.deque[Exchange] = collections.deque()   # commands
        self._polls: collections.deque[Exchange] = collections.deque()   # polls
        self._stop = threading.Event()
        self._port: Serial | None = None
        self._up = False
        self._reason = "not opened"
        self._buf = bytearray()
        self._partial_since = 0.0          # a line from the robot began arriving then
        self._thread: threading.Thread | None = None
        self._poll: float | None = POLL_S
        # the I/O thread's wake pipe (a port with a descriptor), when it next looks, and
        # the byte length of the last line of each kind (a reply's, "!" a notice's)
        self._wake_r: int | None = None
        self._wake_w: int | None = None
        self._look_at = 0.0
        self._line_bytes: dict[str, int] = {}
        self._last_write = 0.0
        # the latched STOP (hold()): only these lines go while held; every (re)connect
        # then writes the stop line before any other byte
        self._held = False
        self.last_stop: Exchange | None = None      # the stop line hold() last sent
        self._held_lines = set(_lines_of(self.commands, ("stop", "version", "sensors",
                                                         "odometry")))
        # the reactions' hold verb (h1 holds, h0 releases), where the table has it
        verb = _lines_of(self.commands, ("hold",))
        self._hold_lines = (verb[0] + "1", verb[0] + "0") if verb else None
        if self._hold_lines is not None:
            self._held_lines.add(self._hold_lines[0])
        self._release_due = False       # an h0 that could not go: sent at the next connect
        self._told_held = False         # the last connect wrote the stop line and h1
        # hold(True) under way: polls wait from the stop line until h1 is written, so
        # that h1 follows the x with no poll between (the window a reaction may fire)
        self._holding = False

    # -- life cycle -----------------------------------------------------------------------
    def open(self) -> None:
        """Connect (raises :class:`LinkError` if the robot cannot be reached now), then
        start the I/O thread."""
        if self._thread is not None:
            raise LinkError(f"link to {self.port} is already open")
        self._port = self._connect()
        self._up, self._reason = True, "up"
        self.up_since = time.monotonic()
        self._wake_r, self._wake_w = os.pipe()
        os.set_blocking(self._wake_r, False)
        os.set_blocking(self._wake_w, False)
        self._thread = threading.Thread(target=self._run, name=f"minlink-io:{self.port}",
                                        daemon=True)
        self._thread.start()
        self._after_up()

    def close(self) -> None:
        """Stop the I/O thread, close the port, fail the commands still in flight."""
        self._stop.set()
        self._wake()
        if self._thread is not None:
            self._thread.join(timeout=5)
        with self._lock:
            self._up, self._reason = False, "closed"
            port, self._port = self._port, None
            self._fail_all(LinkDown(f"link to {self.port} closed"))
        _close_quietly(port)
        if self._thread is None or not self._thread.is_alive():
            for fd in (self._wake_r, self._wake_w):
                if fd is not None:
                    os.close(fd)
            self._wake_r = self._wake_w = None

    def __enter__(self) -> "Link":
        self.open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def up(self) -> bool:
        return self._up

    @property
    def reason(self) -> str:
        return self._reason

    @property
    def alive(self) -> bool:
        """True while the I/O thread runs."""
        return self._thread is not None and self._thread.is_alive()

    @property
    def in_flight(self) -> int:
        """Commands written whose replies have not come yet."""
        return len(self._flight)

    @property
    def waiting(self) -> int:
        """Commands and polls waiting for their turn."""
        return len(self._queue) + len(self._polls)

    # -- commands -------------------------------------------------------------------------
    def exchange(self, line: str, timeout: float | None = None, deadline: float | None = None,
                 asked: float | None = None, poll: bool = False,
                 urgent: bool = False) -> Exchange:
        """Send ``line``, wait for its reply; raise on an ``Enn`` reply or a link down.
        ``deadline`` (``time.monotonic()``, default: ``timeout`` from now): written by
        then or dropped (:class:`Expired`); ``asked``: when the command was asked, to
        refuse one asked before the link came up (both only decide whether it is sent);
        ``poll``: a poll, which waits while commands wait."""
        timeout = self.timeout if timeout is None else timeout
        now = time.monotonic()
        deadline = now + timeout if deadline is None else min(deadline, now + timeout)
        if self._stop.is_set():
            raise LinkDown(f"link to {self.port} is closed: {line!r} not sent")
        if self._held and not poll and not self._may_pass(line):
            self.stats.add("held")
            raise Held(f"link to {self.port} is held (the robot is STOPPED): {line!r} not sent")
        if not self._up:
            raise LinkDown(f"link to {self.port} is down ({self._reason}): {line!r} not sent")
        # the shape of its OK: a bare one, or its action's data (never two alike in flight)
        kind = "bare" if self.commands.plausible(line, "") else (
            self.commands.action_of(line) or line)
        ex = Exchange(line, self.commands.wire(line), timeout, deadline, poll, kind)
        with self._lock:
            if not self._up or self._port is None:
                raise LinkDown(f"link to {self.port} is down ({self._reason}): "
                               f"{line!r} not sent")
            if asked is not None and asked < self.up_since:
                self.stats.add("expired")
                raise Expired(f"link to {self.port}: {line!r} was asked before the link "
                              f"came back; dropped")
            if now > deadline:
                self.stats.add("expired")
                raise Expired(self._expired_text(ex))
            ahead = (self._queue and not urgent) or (poll and self._polls)
            if not ahead and self._may_go(ex):
                self._write_started([self._start(ex)])      # releases _write_lock
            elif urgent:                     # the stop line: ahead of every command
                self._queue.appendleft(ex)
            elif len(self._queue) + len(self._polls) >= QUEUE_MAX:
                self.stats.add("busy")
                raise LinkError(f"link to {self.port} busy: {QUEUE_MAX} commands wait; "
                                f"{line!r} not sent")
            else:
                (self._polls if poll else self._queue).append(ex)
        if not ex.started.wait(max(0.0, deadline - time.monotonic())):
            with self._lock:
                waiting = ex in self._queue or ex in self._polls
                if waiting:
                    (self._polls if poll else self._queue).remove(ex)
            if waiting:
                self.stats.add("expired")
                raise Expired(self._expired_text(ex))
        # the I/O thread owns the deadline; this wait is only a safety net
        if not ex.done.wait(2 * timeout + 2 * self.settle_s + 5.0):
            raise LinkError(f"link to {self.port}: the I/O thread did not answer")
        if ex.error is not None:
            raise ex.error
        return ex

    # -- the latched STOP -------------------------------------------------------------------
    def hold(self, on: bool) -> Exchange | None:
        """Hold (the module docstring, "Held") or let go. Holding fails every command
        waiting and sends the stop line ahead of the rest; it returns that exchange
        once answered (None: the link is down, the next connect sends it first, or its
        reply did not come), after which ``h1`` holds the firmware's reactions. Letting
        go sends ``h0`` (at the next connect if it cannot go now)."""
        with self._lock:
            self._held = on
            self._release_due = False
            waiting = [] if not on else [
                ex for ex in self._queue if not ex.poll and not self._may_pass(ex.line)]
            for ex in waiting:
                self._queue.remove(ex)
                ex.error = Held(f"link to {self.port} is held (the robot is STOPPED): "
                                f"{ex.line!r} not sent")
                ex.started.set()
                ex.done.set()
        if not on:
            if not self._send_hold(False):
                self._release_due = True
            return None
        self.stats.add("holds")
        with self._lock:
            self._holding = self._hold_lines is not None
        try:
            ex = self.send_stop()
            if ex is not None:
                self._send_hold(True)
        finally:
            with self._lock:
                held_polls, self._holding = self._holding, False
            if held_polls:          # h1 did not go: the polls that waited go now
                self._release()
        return ex

    @property
    def held(self) -> bool:
        return self._held

    def send_stop(self) -> Exchange | None:
        """The stop line, ahead of every waiting command; its exchange, or None when it
        could not go now (down: the next connect sends it first while held)."""
        try:
            ex = self.exchange(self.commands.prefix("stop"), urgent=True)
        except LinkError:
            self.stats.add("stops_failed")
            self.last_stop = None
            return None
        self.stats.add("stops_sent")
        self.last_stop = ex
        return ex

    def _send_hold(self, on: bool) -> bool:
        """The reactions' hold line (``h1``/``h0``) ahead of waiting commands; False
        when it could not go (True for a robot without the verb: nothing to say)."""
        if self._hold_lines is None:
            return True
        try:
            self.exchange(self._hold_lines[0 if on else 1], urgent=True)
        except LinkError:
            self.stats.add("hold_lines_failed")
            return False
        self.stats.add("hold_lines_sent")
        return True

    def _may_pass(self, line: str) -> bool:
        return line in self._held_lines

    def _expired_text(self, ex: Exchange) -> str:
        return f"link to {self.port}: {ex.line!r} not written within its deadline; dropped"

    def _may_go(self, ex: Exchange) -> bool:
        """(lock held) May ``ex`` be written now? (the module docstring, "Full duplex")"""
        if ex.poll and self._holding:
            return False                    # h1 goes first (hold())
        flight = self._flight
        if not flight:
            return True
        if len(flight) >= self.max_in_flight:
            return False
        head = flight[0]
        return (head.settle_until is None and self._partial_since > head.t_sent
                and all(f.kind != ex.kind for f in flight)
                and sum(f.sent_bytes for f in flight) + len(RESYNC) + len(ex.wire) <= RX_RING)

    def _start(self, ex: Exchange) -> _Start:
        """(lock held) ``ex`` is in flight from now: the port and the bytes to write.
        Takes ``_write_lock``: the caller writes with :meth:`_write_started`."""
        now = time.monotonic()
        wire = ex.wire if now - self._last_write < RESYNC_IDLE_S else RESYNC + ex.wire
        # sent before the write: its reply may come before write() returns
        ex.sent, ex.t_sent, ex.sent_bytes = True, now, len(wire)
        if self._holding and self._hold_lines is not None and ex.line == self._hold_lines[0]:
            self._holding = False           # h1 written: the polls may follow it
        if self._flight:
            self.stats.add("duplex")               # written while a reply arrives
        self._last_write = now
        self._flight.append(ex)
        ex.started.set()
        if now + ex.timeout < self._look_at:
            self._wake()                    # due before the I/O thread's next look
        assert self._port is not None       # _pump starts exchanges while the port is open
        return ex, self._port, wire

    def _pump(self) -> tuple[list[_Start], list[Exchange]]:
        """(lock held) Start what may go now, commands before polls; drop what waited
        past its deadline (never written late). Returns (started, expired)."""
        starts: list[_Start] = []
        expired: list[Exchange] = []
        now = time.monotonic()
        while self._up and self._port is not None:
            queue = self._queue or self._polls
            if not queue:
                break
            nxt = queue[0]
            if nxt.deadline < now:
                expired.append(queue.popleft())
                continue
            if not self._may_go(nxt):
                break
            queue.popleft()
            starts.append(self._start(nxt))
        return starts, expired

    def _write_started(self, starts: list[_Start]) -> None:
        """Write the lines just started, in order. Called with ``_lock`` held: takes
        ``_write_lock`` before that is released (by the caller), so no later line
        overtakes; a port error takes the link down after."""
        if not starts:
            return
        self._write_lock.acquire()
        self._lock.release()
        failed: tuple[str, Serial] | None = None
        try:
            for ex, port, wire in starts:
                try:
                    port.write(wire)
                    self.stats.add("sent")
                except Exception as exc:  # noqa: BLE001 - pySerial's errors vary
                    ex.sent = False             # the error says: not sent
                    failed = (describe(exc), port)
                    break
        finally:
            self._write_lock.release()
            if failed is not None:
                self._down(*failed)
            self._lock.acquire()

    def command(self, line: str, timeout: float | None = None, deadline: float | None = None,
                asked: float | None = None, poll: bool = False) -> str:
        """Send ``line``; return the reply's data (after ``OK ``, empty for a bare ``OK``)."""
        data = self.exchange(line, timeout, deadline, asked, poll).data
        assert data is not None
        return data

    def motor(self, servo: str, angle: object, speed: object = None) -> None:
        self.command(self.commands.motor(servo, angle, speed))

    def play(self, motion: object) -> None:
        self.command(self.commands.play(motion))

    def stand(self) -> None:
        self.command(self.commands.prefix("stand"))

    def stop(self) -> None:
        self.command(self.commands.prefix("stop"))

    def feet(self, poll: bool = False) -> JSONObject:
        """The ``s`` reply as a sample value; ``poll``: waits while commands wait."""
        return self.commands.feet(self.command(self.commands.prefix("sensors"), poll=poll))

    def version(self) -> str:
        return self.command(self.commands.prefix("version"))

    # -- notices --------------------------------------------------------------------------
    def notices(self) -> list[tuple[str, float]]:
        """Drain the notices received (``!`` removed) with their ``time.time()``."""
        with self._lock:
            out = list(self._notices)
            self._notices.clear()
        return out

    # -- the I/O thread -------------------------------------------------------------------
    def _wake(self) -> None:
        """Make the I/O thread look now (closing; a reply deadline sooner than it knew)."""
        if self._wake_w is not None:
            try:
                os.write(self._wake_w, b"x")
            except OSError:         # full (a wake is pending anyway) or closed
                pass
        port = self._port
        cancel = getattr(port, "cancel_read", None)
        if cancel is not None:
            try:
                cancel()
            except Exception:  # noqa: BLE001 - a port closing under us: the loop sees it
                pass

    def _run(self) -> None:
        while not self._stop.is_set():
            if self._port is None:
                self._reconnect()
                continue
            port = self._port
            try:
                if self._wake_r is not None and _fd_of(port) is not None:
                    self._service_fd(port)
                else:
                    self._service()
            except (OSError, Exception) as exc:  # noqa: BLE001 - pySerial's errors vary
                if self._stop.is_set():
                    break
                self._down(describe(exc), port)

    def _service(self) -> None:
        """A port without a descriptor (a URL's): short reads, its timeout the pace."""
        port = self._port
        assert port is not None     # else taken down meanwhile: _run's except, as any error
        data = port.read(1)
        if data:
            more = port.in_waiting
            if more:
                data += port.read(more)
            self._take(data)
        self._check_head(time.monotonic())

    def _service_fd(self, port: Serial) -> None:
        """A device or pty: sleep in select until bytes come, a reply's deadline, or a
        wake; then read all there is. A line begun is read whole: the thread waits out
        the bytes its kind's last line had (at the baud rate) instead of waking for each."""
        fd = _fd_of(port)
        assert fd is not None and self._wake_r is not None
        with self._lock:
            now = time.monotonic()
            look = min(self._head_due(), now + IDLE_LOOK_S)
            self._look_at = look
        ready, _, _ = select.select([fd, self._wake_r], [], [], max(0.0, look - now))
        self.stats.add("wakes")             # the thread's wake-ups (a quiet line: few)
        if self._wake_r in ready:
            _drain(self._wake_r)
        if fd in ready:
            self._take(_read_fd(port, ready=True))
            while self._buf and self._port is port and not self._stop.is_set():
                wait = self.budget.line_s(self._rest_of_line())
                self._look_at = time.monotonic() + wait
                if select.select([self._wake_r], [], [], wait)[0]:
                    _drain(self._wake_r)
                self.stats.add("wakes")
                data = _read_fd(port)
                if not data:
                    break               # the line pauses: select waits for its next byte
                self._take(data)
                self._check_head(time.monotonic())
        self._check_head(time.monotonic())

    def _head_due(self) -> float:
        """(lock held) When the oldest command in flight is next due a look: the end
        of its settle time, or of its reply timeout (inf: nothing in flight)."""
        head = self._flight[0] if self._flight else None
        if head is None or not head.sent or head.done.is_set():
            return float("inf")
        if head.settle_until is not None:
            return head.settle_until
        return head.t_sent + head.timeout + DUE_SLACK_S

    def _rest_of_line(self) -> int:
        """Bytes the line begun in the buffer likely still needs (at least a few)."""
        have = len(self._buf)
        expect = self._line_bytes.get(self._line_kind(), 0)
        return expect - have if expect > have else GATHER_BYTES

    def _line_kind(self) -> str:
        """The kind the line now arriving is counted under: a notice, or the reply to
        the oldest command in flight."""
        if self._buf[:1] == b"!":
            return "!"
        head = self._flight[0] if self._flight else None
        return head.kind if head is not None else ""

    def _check_head(self, now: float) -> None:
        head = self._flight[0] if self._flight else None
        if head is None or not head.sent or head.done.is_set():
            return
        if head.settle_until is not None and now >= head.settle_until:
            self._settled(head)
        elif head.settle_until is None and now - head.t_sent > head.timeout:
            self.stats.add("timeouts")
            self._down(f"no reply to {head.line!r} within {head.timeout:g} s")

    def _take(self, data: bytes) -> None:
        self._buf += data
        ended = False
        while True:
            i = self._buf.find(b"\n")
            if i < 0:
                if len(self._buf) > MAX_LINE_BYTES:
                    self._buf.clear()
                    self.stats.add("garbled")
                break
            self._line_bytes[self._line_kind()] = i + 1
            raw = bytes(self._buf[:i])
            del self._buf[:i + 1]
            text = raw.decode("latin-1").strip("\r")
            ended = True
            if text:
                self._line(text)
        if not self._buf:
            self._partial_since = 0.0
        elif ended or not self._partial_since:
            # a line has begun to arrive: the robot answers; what waits may go now
            self._partial_since = time.monotonic()
            if self._queue or self._polls:
                self._release()

    def _line(self, text: str) -> None:
        if text.startswith("!"):
            self.stats.add("notices")
            t = time.time()
            with self._lock:
                if len(self._notices) == self._notices.maxlen:
                    self.stats.add("notices_dropped")
                self._notices.append((text[1:], t))
            if self.on_notice is not None:
                self.on_notice(text[1:], t)
            if text.startswith("!H "):
                self.stats.add("reactions_held")      # the firmware held it: nothing moved
            elif self._held and text.startswith(("!R ", "!READY")):
                # a reaction moves (not held yet, or no verb), or the robot was reset,
                # which released its reactions: stop it and hold them again
                self.stats.add("reactions_stopped" if text.startswith("!R ")
                               else "resets_while_held")
                threading.Thread(target=self._hold_again, name="minlink-hold",
                                 daemon=True).start()
            return
        try:
            reply = parse_reply(text)
        except ProtocolError:
            self.stats.add("garbled")
            return
        flight = list(self._flight)
        if not flight or not flight[0].sent or flight[0].done.is_set():
            self.stats.add("strays")
            return
        head, second = flight[0], (flight[1] if len(flight) > 1 else None)
        if reply.kind == "ok":
            if self.commands.plausible(head.line, reply.data):
                self._finish(head, data=reply.data)
            elif (head.settle_until is not None and second is not None
                    and self.commands.plausible(second.line, reply.data)):
                # the second's reply: the head's error before it was the head's own
                self._settled(head)
                self._finish(second, data=reply.data)
            else:
                self.stats.add("strays")
            return
        assert reply.code is not None
        refused = RobotRefused(head.line, reply.code, text)
        if head.settle_until is None:
            if reply.code in WIRE_CODES:
                head.first_error = refused
                head.settle_until = time.monotonic() + self.settle_s
            else:
                self._finish(head, error=refused)
        elif second is None:
            self.stats.add("strays")
        elif reply.code in WIRE_CODES:
            # noise's, the head's, or the second's: the second's candidate
            head.later_error = RobotRefused(second.line, reply.code, text)
        else:
            self._down(f"{OUT_OF_STEP}: {text!r} after a damaged line answers "
                       f"{head.line!r} or {second.line!r}")

    def _settled(self, head: Exchange) -> None:
        """No plausible ``OK`` came for ``head`` within its settle time (or the second
        command's came): its wire error was its own. A later wire error becomes the
        next command's candidate error."""
        assert head.first_error is not None
        self._last_write = 0.0              # the next command resyncs the robot's line
        later = head.later_error
        if later is not None and len(self._flight) > 1:
            second = self._flight[1]
            second.first_error = later
            second.settle_until = time.monotonic() + self.settle_s
        self._finish(head, error=head.first_error)

    def _finish(self, ex: Exchange, data: str | None = None,
                error: LinkError | None = None) -> None:
        ex.t_reply = time.monotonic()
        ex.data, ex.error = data, error
        self.stats.add("refused" if isinstance(error, RobotRefused) else "ok")
        with self._lock:
            if self._flight and self._flight[0] is ex:
                self._flight.popleft()
        self._release()                     # the next commands go out before this
        ex.done.set()                       # one's caller is woken

    def _release(self) -> None:
        """Write what may go now; fail what waited past its deadline."""
        with self._lock:
            starts, expired = self._pump()
            self._write_started(starts)
        for late in expired:
            self.stats.add("expired")
            late.error = Expired(self._expired_text(late))
            late.started.set()
            late.done.set()

    def _fail_all(self, error: LinkError) -> None:
        """(lock held) Fail the commands in flight and those waiting their turn."""
        for q in (*self._queue, *self._polls):
            q.error = LinkDown(f"link to {self.port} is down ({error}): {q.line!r} not sent")
            q.started.set()
            q.done.set()
        self._queue.clear()
        self._polls.clear()
        flight = list(self._flight)
        self._flight.clear()
        for ex in flight:
            if ex.done.is_set():
                continue
            if ex.sent:
                ex.error = LinkDown(f"link to {self.port} went down while {ex.line!r} waited "
                                    f"for its reply ({error})")
            else:
                ex.error = LinkDown(f"link to {self.port} is down ({error}): {ex.line!r} "
                                    f"not sent")
            ex.done.set()

    def _down(self, reason: str, failed: Serial | None = None) -> None:
        """The link is down: fail the commands in flight, close the port (the I/O thread
        reopens it). ``failed``: the port an error came from; if the link has moved on
        from it (the other thread took it down first), nothing more is done."""
        with self._lock:
            if failed is not None and self._port is not failed:
                return
            port, self._port = self._port, None
            self._up, self._reason = False, reason
            self._fail_all(LinkError(reason))
        self._buf.clear()
        self._partial_since = 0.0
        _close_quietly(port)
        self.stats.add("downs")
        if self.on_state is not None:
            self.on_state(False, reason)

    def _reconnect(self) -> None:
        delay = self.backoff[0]
        told = ""
        while not self._wait_or_port_made(delay):
            held = self.may_open() if self.may_open is not None else None
            try:
                if held is not None:
                    raise LinkDown(held)
                port = self._connect()
            except LinkError as exc:
                self._reason = f"reconnecting: {exc}"
                final = isinstance(exc, DifferentRobot) or held is not None
                if final and str(exc) != told and self.on_state is not None:
                    told = str(exc)                 # said once, not at every attempt
                    self.on_state(False, told)
                delay = min(delay * 2, self.backoff[1])
                continue
            with self._lock:
                if self._stop.is_set():
                    _close_quietly(port)
                    return
                self._port, self._up, self._reason = port, True, "up"
                self.up_since = time.monotonic()
            self.stats.add("reconnects")
            if self.on_state is not None:
                self.on_state(True, "up")
            self._after_up()
            return

    def _wait_or_port_made(self, delay: float) -> bool:
        """Wait ``delay`` before the next try (True: the link closes), or less: a port
        made anew meanwhile (a device plugged in, a link the emulated robot's start
        replaced) is tried at once. A port that stays as it was waits out the backoff."""
        seen = _port_node(self.port)
        end = time.monotonic() + delay
        while (left := end - time.monotonic()) > 0:
            if self._stop.wait(min(left, PORT_LOOK_S)):
                return True
            if _port_node(self.port) != seen:
                return False
        return self._stop.is_set()

    def _connect(self) -> Serial:
        """Open the port and probe it with ``v``; the robot must be the board files' one."""
        import serial

        pty = pty_identity(self.port)
        if stale_pty(self._pty, pty):
            raise PtyGone(f"the pty behind {self.port} went away and its number "
                          f"({os.path.realpath(self.port)}) now leads to another program's "
                          f"pty: not opened (name the robot's new port, or a link that "
                          f"follows it, as port: emulate does)")
        deadline, wait = time.monotonic() + LOCK_WAIT_S, 0.02
        while True:
            try:
                port: Serial = open_port(self.port, baudrate=self.baud, timeout=POLL_S,
                                         write_timeout=self.timeout)
                break
            except (serial.SerialException, ValueError, OSError) as exc:
                why = describe(exc)
                if why != LOCKED:
                    raise LinkError(f"cannot open {self.port}: {why}") from None
                self.stats.add("port_locked")
                left = deadline - time.monotonic()
                if left <= 0 or self._stop.wait(min(wait, left)):
                    raise LinkError(f"cannot open {self.port}: {why}") from None
                wait *= 2
        try:
            if getattr(port, "cancel_read", None) is None:
                port.timeout = POLL_S_NO_CANCEL
            self._poll = port.timeout
            port.reset_input_buffer()
            self._told_held = self._held
            if self._told_held:     # a STOP made while down: before any other byte
                wire = RESYNC + self.commands.wire(self.commands.prefix("stop"))
                if self._hold_lines is not None:   # and h1: a reset releases reactions
                    wire += self.commands.wire(self._hold_lines[0])
                port.write(wire)
                self.stats.add("stops_on_connect")
            self._probe(port)
            self._pty = pty
        except LinkError:
            _close_quietly(port)
            raise
        except Exception as exc:  # noqa: BLE001 - pySerial's errors vary
            _close_quietly(port)
            raise LinkError(f"cannot open {self.port}: {describe(exc)}") from None
        return port

    def _after_up(self) -> None:
        """What changed while the connect was under way: a STOP its first bytes did not
        carry (hold() could not send while the link was not up), or a release due."""
        if self._held and not self._told_held:
            threading.Thread(target=self._hold_again, name="minlink-hold",
                             daemon=True).start()
        elif self._release_due and not self._held:
            threading.Thread(target=self._send_release, name="minlink-release",
                             daemon=True).start()

    def _hold_again(self) -> None:
        if self.send_stop() is not None:
            self._send_hold(True)

    def _send_release(self) -> None:
        """The ``h0`` a release could not send (the link was down), now it is back."""
        if self._send_hold(False):
            self._release_due = False

    def _probe(self, port: Serial, attempts: int = 4) -> None:
        """Send ``v`` until a version reply comes (a noisy line may damage a few). A line
        end goes first: it ends whatever noise left in the robot's line buffer. A reply
        that is not the board files' robot is believed only when the next one says the
        same: without checksums, noise can turn ``sensors=8`` into ``sensors=``."""
        wire = RESYNC + self.commands.wire(self.commands.prefix("version"))
        buf = bytearray()
        doubt: tuple[str, LinkError] | None = None
        for _ in range(attempts):
            port.write(wire)
            deadline = time.monotonic() + self.timeout
            while time.monotonic() < deadline:
                buf += port.read(1)
                if b"\n" not in buf:
                    continue
                raw, _, rest = bytes(buf).partition(b"\n")
                buf[:] = rest
                text = raw.decode("latin-1").strip("\r")
                if text.startswith("!"):
                    self._line(text)
                elif text.startswith("OK " + VERSION_PREFIX):
                    try:
                        self._check_identity(text[3:])
                        return
                    except LinkError as exc:
                        if doubt is not None and doubt[0] == text:
                            raise
                        doubt = (text, exc)
                        break                            # ask again
                elif text.startswith("E11") and not self.commands.checksum:
                    raise LinkError(f"the robot on {self.port} requires checksums (E11) but "
                                    f"the board files of {self.robot.name} say "
                                    f"require_checksum: false ({self.robot.source})")
        if doubt is not None:
            raise doubt[1]
        raise LinkError(f"no answer to 'v' from {self.port} within {self.timeout:g} s")

    def _check_identity(self, data: str) -> None:
        """The ``v`` reply ``data``: once the link knows the robot, its ``id=`` (or its
        lack of one) must be the same (another id is a different robot, whatever its
        model); then the robot of the board files (counts, checksum); then it is known."""
        got = dict(f.split("=", 1) for f in data.split()[1:] if "=" in f).get("id")
        if self._known and got != self.robot_id:
            raise DifferentRobot(f"{DIFFERENT_ROBOT} {self.port} (id {got or 'none'}, "
                                 f"expected {self.robot_id or 'none'})")
        self.commands.check_version(data)
        self.robot_id, self._known = got, True


def _lines_of(commands: RobotCommands, actions: tuple[str, ...]) -> list[str]:
    """The lines of those of ``actions`` the command set has (no argument: stop, reads)."""
    out = []
    for action in actions:
        try:
            out.append(commands.prefix(action))
        except LinkError:
            pass
    return out


def _port_node(path: str) -> tuple[int, int, int] | None:
    """The port's file itself (a symbolic link not followed): made anew, it differs."""
    try:
        st = os.lstat(path)
    except (OSError, ValueError):           # none (unplugged), or a URL, not a file
        return None
    return st.st_dev, st.st_ino, st.st_ctime_ns


def _fd_of(port: Serial) -> int | None:
    """The descriptor of a device or pty port (None: a URL's port, read through pySerial)."""
    fd = getattr(port, "fd", None)
    return fd if isinstance(fd, int) and hasattr(port, "pipe_abort_read_r") else None


def _read_fd(port: Serial, ready: bool = False) -> bytes:
    """What the port has (b"" if nothing yet: pySerial sets VMIN 0); pySerial's errors,
    in its words, for a port closed meanwhile, that failed, or hung up (``ready``:
    select said readable). Its descriptor is asked at each read: a closed port has none
    (its number may be another file's by then)."""
    from serial import PortNotOpenError, SerialException

    fd = port.fd
    if fd is None:
        raise PortNotOpenError()
    try:
        data = os.read(fd, 4096)
    except (BlockingIOError, InterruptedError):
        return b""
    except OSError as exc:
        raise SerialException(f"read failed: {exc}") from None
    if not data and ready:
        raise SerialException("device reports readiness to read but returned no data "
                              "(device disconnected or multiple access on port?)")
    return data


def _drain(fd: int) -> None:
    try:
        os.read(fd, 4096)
    except OSError:
        pass


def _close_quietly(port: Serial | None) -> None:
    if port is None:
        return
    try:
        port.close()
    except Exception:  # noqa: BLE001 - closing a port that already failed
        pass
