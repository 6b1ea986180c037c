"""One MIN robot's serial link: one command in flight, replies matched, notices apart.

An I/O thread reads the port (pySerial: a device, a pty, an ``esair://`` URL). A caller
of :meth:`Link.command` that finds the link idle writes its line itself (no hand-off to
another thread before the bytes leave, which cost 0.05-0.15 ms a command); one that finds
a command in flight waits in a queue (FIFO, bounded), and the I/O thread writes the next
queued line the moment it has matched the reply before it, so the line never idles
while commands wait (one writer at a time, as pySerial's ports allow). Each caller then
waits for the I/O thread to see the line that answers its command; ``!`` lines go to the notices
stream (bounded; what overflows is counted). An ``Enn`` reply raises
:class:`RobotRefused` in the caller, naming the command and the code.

The protocol's replies carry no sequence number, so the link keeps them matched by
never having two commands out and by resynchronising whenever it cannot be sure:

- an ``OK`` whose shape cannot answer the command in flight (a ``v`` reply to ``s``...)
  is a stray, counted, not a reply;
- an error that only a damaged line can cause (E01 E02 E03 E06 E12 E13: the link only
  sends well-formed lines) may be the answer to a line that noise made up, so the link
  waits ``settle_s`` for a later, plausible ``OK`` before it reports the error;
- no reply within ``timeout``, or a port error: the link is **down**. The command in
  flight fails with :class:`LinkDown`, the port is closed, and the I/O thread reopens
  it with exponential backoff; it is up again once a ``v`` probe is answered by the robot
  of the board files (servo and sensor count, checksum setting). While down, commands
  fail at once with :class:`LinkDown`; ``on_state`` reports every change.

The robot must be the same one after every reconnect: once the link knows the robot's
``id=`` (docs/protocol.md, "Robot id"; from ``expect_id``, or the first connect, where
a robot without one is known as such) a reconnect to a robot of another id is refused
(:class:`DifferentRobot`, reported by ``on_state``), the port closed again at once: the
only line it got was the read-only ``v`` probe. ``may_open`` (if given) is asked
before each reconnect; a reason from it keeps the port closed (the driver's emulated
robot that exited: its pty may belong to another program by now).

Deadlines: a command carries one (``deadline``, a ``time.monotonic()``; by default its
``timeout`` from the call). A command not written by then fails with :class:`Expired`
and is dropped, never sent; so does one ``asked`` before the link last came up.

:meth:`close` stops and joins the I/O thread and closes the port.
"""

from __future__ import annotations

import collections
import threading
import time
from dataclasses import dataclass, field
from typing import Any, Callable

from esair_min.errors import ProtocolError
from esair_min.core.protocol import Code, parse_reply
from esair_min.model.robot import Robot

from .budget import LineBudget, line_budget
from .commands import VERSION_PREFIX, RobotCommands
from .errors import DifferentRobot, Expired, LinkDown, LinkError, RobotRefused

#: Reply codes a well-formed line cannot get: the line was damaged on the wire.
WIRE_CODES = frozenset({Code.UNKNOWN, Code.TOO_LONG, Code.BAD_ARGUMENT, Code.BAD_CHECKSUM,
                        Code.OVERRUN, Code.BAD_CHARACTER})
MAX_LINE_BYTES = 256        # a longer line from the robot is garbage: dropped, counted
POLL_S = 0.05               # the I/O thread's longest wait on a port it can wake
POLL_S_NO_CANCEL = 0.002    # ... on a port without cancel_read
RESYNC = b"\r\n"            # an empty line: no reply, but it ends a line noise began
RESYNC_IDLE_S = 0.25        # a command after this long a silence is sent after RESYNC
QUEUE_MAX = 64              # commands waiting for their turn; more are refused, not sent
DIFFERENT_ROBOT = "a different robot answers on"


@dataclass
class Exchange:
    """One command and its fate. Times are ``time.monotonic()``."""

    line: str
    wire: bytes
    timeout: float
    deadline: float = float("inf")   # not written by then: Expired, dropped
    sent: bool = False
    t_sent: float = 0.0
    t_reply: float = 0.0
    data: str | None = None
    error: LinkError | None = None
    settle_until: float | None = None
    first_error: RobotRefused | None = None
    started: threading.Event = field(default_factory=threading.Event)   # its turn came
    done: threading.Event = field(default_factory=threading.Event)


StateCallback = Callable[[bool, str], None]
NoticeCallback = Callable[[str, float], None]


class Link:
    """The serial link to one MIN robot (see the module docstring)."""

    def __init__(self, robot: Robot, port: str, *, baud: int | None = None,
                 timeout: float = 1.0, backoff: tuple[float, float] = (0.05, 2.0),
                 notice_capacity: int = 256, on_state: StateCallback | None = None,
                 on_notice: NoticeCallback | None = None, expect_id: str | None = None,
                 may_open: Callable[[], str | None] | None = None,
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
        self.settle_s = (self.budget.line_s(2 * 44) + 2 * self.budget.tick_s)
        self.on_state = on_state
        self.on_notice = on_notice
        self.robot_id = expect_id          # the robot's id= (None: it answers none)
        self._known = expect_id is not None  # else learnt at the first connect
        self.may_open = may_open
        self.up_since = 0.0                # time.monotonic() of the last connect
        self.stats: collections.Counter[str] = collections.Counter()
        self._notices: collections.deque[tuple[str, float]] = collections.deque(
            maxlen=notice_capacity)
        self._lock = threading.Lock()          # guards _slot, _queue, _port, _up, _reason
        self._write_lock = threading.Lock()    # one writer at a time
        self._queue: collections.deque[Exchange] = collections.deque()
        self._stop = threading.Event()
        self._port: Any = None
        self._slot: Exchange | None = None
        self._up = False
        self._reason = "not opened"
        self._buf = bytearray()
        self._thread: threading.Thread | None = None
        self._poll: float | None = POLL_S
        self._last_write = 0.0

    # -- life cycle -----------------------------------------------------------------------
    def open(self) -> None:
        """Connect (raises :class:`LinkError` if the robot cannot be reached now), then
        start the I/O thread."""
        if self._thread is not None:
            raise LinkError(f"link to {self.port} is already open")
        self._port = self._connect()
        self._up, self._reason = True, "up"
        self.up_since = time.monotonic()
        self._thread = threading.Thread(target=self._run, name=f"minlink-io:{self.port}",
                                        daemon=True)
        self._thread.start()

    def close(self) -> None:
        """Stop the I/O thread, close the port, fail a command still in flight."""
        self._stop.set()
        self._wake()
        if self._thread is not None:
            self._thread.join(timeout=5)
        with self._lock:
            self._up, self._reason = False, "closed"
            port, self._port = self._port, None
            self._fail_slot(LinkDown(f"link to {self.port} closed"))
        _close_quietly(port)

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

    # -- commands -------------------------------------------------------------------------
    def exchange(self, line: str, timeout: float | None = None, deadline: float | None = None,
                 asked: float | None = None) -> Exchange:
        """Send ``line``, wait for its reply; raise on an ``Enn`` reply or a link down.
        ``deadline`` (``time.monotonic()``, default: ``timeout`` from now): written by
        then or dropped (:class:`Expired`); ``asked``: when the command was asked, to
        refuse one asked before the link came up (both only decide whether it is sent)."""
        timeout = self.timeout if timeout is None else timeout
        now = time.monotonic()
        deadline = now + timeout if deadline is None else min(deadline, now + timeout)
        if self._stop.is_set():
            raise LinkDown(f"link to {self.port} is closed: {line!r} not sent")
        if not self._up:
            raise LinkDown(f"link to {self.port} is down ({self._reason}): {line!r} not sent")
        ex = Exchange(line, self.commands.wire(line), timeout, deadline)
        start = None
        with self._lock:
            if not self._up or self._port is None:
                raise LinkDown(f"link to {self.port} is down ({self._reason}): "
                               f"{line!r} not sent")
            if asked is not None and asked < self.up_since:
                self.stats["expired"] += 1
                raise Expired(f"link to {self.port}: {line!r} was asked before the link "
                              f"came back; dropped")
            if now > deadline:
                self.stats["expired"] += 1
                raise Expired(self._expired_text(ex))
            if self._slot is None and not self._queue:
                start = self._start(ex)
            elif len(self._queue) >= QUEUE_MAX:
                self.stats["busy"] += 1
                raise LinkError(f"link to {self.port} busy: {QUEUE_MAX} commands wait; "
                                f"{line!r} not sent")
            else:
                self._queue.append(ex)
        if start is not None:
            self._write(ex, *start)
        elif not ex.started.wait(max(0.0, deadline - time.monotonic())):
            with self._lock:
                waiting = ex in self._queue
                if waiting:
                    self._queue.remove(ex)
            if waiting:
                self.stats["expired"] += 1
                raise Expired(self._expired_text(ex))
        # the I/O thread owns the deadline; this wait is only a safety net
        if not ex.done.wait(timeout + self.settle_s + 5.0):
            raise LinkError(f"link to {self.port}: the I/O thread did not answer")
        if ex.error is not None:
            raise ex.error
        return ex

    def _expired_text(self, ex: Exchange) -> str:
        return f"link to {self.port}: {ex.line!r} not written within its deadline; dropped"

    def _start(self, ex: Exchange) -> tuple[Any, bytes]:
        """(lock held) ``ex`` is in flight from now: the port and the bytes to write."""
        now = time.monotonic()
        wire = ex.wire if now - self._last_write < RESYNC_IDLE_S else RESYNC + ex.wire
        # sent before the write: its reply may come before write() returns
        ex.sent, ex.t_sent = True, now
        self._last_write = now
        self._slot = ex
        ex.started.set()
        return self._port, wire

    def _write(self, ex: Exchange, port: Any, wire: bytes) -> None:
        try:
            with self._write_lock:
                port.write(wire)
            self.stats["sent"] += 1
        except Exception as exc:  # noqa: BLE001 - pySerial's errors vary
            ex.sent = False                 # the error says: not sent
            self._down(_describe(exc), port)

    def command(self, line: str, timeout: float | None = None, deadline: float | None = None,
                asked: float | None = None) -> str:
        """Send ``line``; return the reply's data (after ``OK ``, empty for a bare ``OK``)."""
        data = self.exchange(line, timeout, deadline, asked).data
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

    def feet(self) -> dict[str, object]:
        return self.commands.feet(self.command(self.commands.prefix("sensors")))

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
                self._service()
            except (OSError, Exception) as exc:  # noqa: BLE001 - pySerial's errors vary
                if self._stop.is_set():
                    break
                self._down(_describe(exc), port)

    def _service(self) -> None:
        port = self._port
        data = port.read(1)
        if data:
            more = port.in_waiting
            if more:
                data += port.read(more)
            self._take(data)
        now = time.monotonic()
        ex = self._slot
        if ex is None or not ex.sent or ex.done.is_set():
            return
        if ex.settle_until is not None and now >= ex.settle_until:
            assert ex.first_error is not None
            self._last_write = 0.0          # the next command resyncs the robot's line
            self._finish(ex, error=ex.first_error)
        elif ex.settle_until is None and now - ex.t_sent > ex.timeout:
            self.stats["timeouts"] += 1
            self._down(f"no reply to {ex.line!r} within {ex.timeout:g} s")

    def _take(self, data: bytes) -> None:
        self._buf += data
        while True:
            i = self._buf.find(b"\n")
            if i < 0:
                if len(self._buf) > MAX_LINE_BYTES:
                    self._buf.clear()
                    self.stats["garbled"] += 1
                return
            raw = bytes(self._buf[:i])
            del self._buf[:i + 1]
            text = raw.decode("latin-1").strip("\r")
            if text:
                self._line(text)

    def _line(self, text: str) -> None:
        if text.startswith("!"):
            self.stats["notices"] += 1
            t = time.time()
            with self._lock:
                if len(self._notices) == self._notices.maxlen:
                    self.stats["notices_dropped"] += 1
                self._notices.append((text[1:], t))
            if self.on_notice is not None:
                self.on_notice(text[1:], t)
            return
        try:
            reply = parse_reply(text)
        except ProtocolError:
            self.stats["garbled"] += 1
            return
        ex = self._slot
        if ex is None or not ex.sent or ex.done.is_set():
            self.stats["strays"] += 1
            return
        if reply.kind == "ok":
            if self.commands.plausible(ex.line, reply.data):
                self._finish(ex, data=reply.data)
            else:
                self.stats["strays"] += 1
            return
        assert reply.code is not None
        refused = RobotRefused(ex.line, reply.code, text)
        if ex.settle_until is not None:
            self.stats["strays"] += 1
        elif reply.code in WIRE_CODES:
            ex.first_error = refused
            ex.settle_until = time.monotonic() + self.settle_s
        else:
            self._finish(ex, error=refused)

    def _finish(self, ex: Exchange, data: str | None = None,
                error: LinkError | None = None) -> None:
        ex.t_reply = time.monotonic()
        ex.data, ex.error = data, error
        self.stats["refused" if isinstance(error, RobotRefused) else "ok"] += 1
        nxt = start = None
        expired: list[Exchange] = []
        with self._lock:
            if self._slot is ex:
                self._slot = None
                now = time.monotonic()
                while self._queue and self._queue[0].deadline < now:
                    expired.append(self._queue.popleft())      # never written late
                if self._queue and self._up and self._port is not None:
                    nxt = self._queue.popleft()
                    start = self._start(nxt)
        for late in expired:
            self.stats["expired"] += 1
            late.error = Expired(self._expired_text(late))
            late.started.set()
            late.done.set()
        if nxt is not None and start is not None:   # the next command goes out before this
            self._write(nxt, *start)        # one's caller is woken
        ex.done.set()

    def _fail_slot(self, error: LinkError) -> None:
        """(lock held) Fail the command in flight, if any, and those waiting their turn."""
        for q in self._queue:
            q.error = LinkDown(f"link to {self.port} is down ({error}): {q.line!r} not sent")
            q.started.set()
            q.done.set()
        self._queue.clear()
        ex, self._slot = self._slot, None
        if ex is not None and not ex.done.is_set():
            if ex.sent:
                error = LinkDown(f"link to {self.port} went down while {ex.line!r} waited for "
                                 f"its reply ({error})")
            else:
                error = LinkDown(f"link to {self.port} is down ({error}): {ex.line!r} not sent")
            ex.error = error
            ex.done.set()

    def _down(self, reason: str, failed: Any = None) -> None:
        """The link is down: fail the command in flight, close the port (the I/O thread
        reopens it). ``failed``: the port an error came from; if the link has moved on
        from it (the other thread took it down first), nothing more is done."""
        with self._lock:
            if failed is not None and self._port is not failed:
                return
            port, self._port = self._port, None
            self._up, self._reason = False, reason
            self._fail_slot(LinkError(reason))
        self._buf.clear()
        _close_quietly(port)
        self.stats["downs"] += 1
        if self.on_state is not None:
            self.on_state(False, reason)

    def _reconnect(self) -> None:
        delay = self.backoff[0]
        told = ""
        while not self._stop.wait(delay):
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
            self.stats["reconnects"] += 1
            if self.on_state is not None:
                self.on_state(True, "up")
            return

    def _connect(self) -> Any:
        """Open the port and probe it with ``v``; the robot must be the board files' one."""
        import serial

        import esair_min.emulator  # noqa: F401  (registers esair://)

        try:
            port = serial.serial_for_url(self.port, baudrate=self.baud, timeout=POLL_S,
                                         write_timeout=self.timeout)
        except (serial.SerialException, ValueError, OSError) as exc:
            raise LinkError(f"cannot open {self.port}: {_describe(exc)}") from None
        try:
            if getattr(port, "cancel_read", None) is None:
                port.timeout = POLL_S_NO_CANCEL
            self._poll = port.timeout
            port.reset_input_buffer()
            self._probe(port)
        except LinkError:
            _close_quietly(port)
            raise
        except Exception as exc:  # noqa: BLE001 - pySerial's errors vary
            _close_quietly(port)
            raise LinkError(f"cannot open {self.port}: {_describe(exc)}") from None
        return port

    def _probe(self, port: Any, attempts: int = 3) -> None:
        """Send ``v`` until a version reply comes (a noisy line may damage a few). A line
        end goes first: it ends whatever noise left in the robot's line buffer."""
        wire = RESYNC + self.commands.wire(self.commands.prefix("version"))
        buf = bytearray()
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
                    self._check_identity(text[3:])
                    return
                elif text.startswith("E11") and not self.commands.checksum:
                    raise LinkError(f"the robot on {self.port} requires checksums (E11) but "
                                    f"the board files of {self.robot.name} say "
                                    f"require_checksum: false ({self.robot.source})")
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


#: pySerial's words for a port that went away, and a user's.
_PLAIN = {"device reports readiness to read but returned no data":
          "the device disconnected (unplugged, or another program uses the port)",
          "[Errno 5] Input/output error": "input/output error (the device unplugged?)"}


def _describe(exc: BaseException) -> str:
    text = str(exc) or type(exc).__name__
    return next((plain for raw, plain in _PLAIN.items() if text.startswith(raw)), text)


def _close_quietly(port: Any) -> None:
    if port is None:
        return
    try:
        port.close()
    except Exception:  # noqa: BLE001 - closing a port that already failed
        pass
