"""The host of one resource entry: a Sensor, an Actuator, or a Driver and its children.

One thread per entry (thread mode) or the agent process's main worker (process mode)
opens the device, polls the sensors that set ``rate_hz``, and runs every ``write()`` and
``configure()`` from one bounded command queue: user code never runs on the caller's
(the AC's, a transport) thread.
"""

from __future__ import annotations

import collections
import logging
import queue
import threading
import time
from typing import TYPE_CHECKING, Callable, Union, cast

from esair_min import sigs

from ..errors import CommandError, ComponentError, ResourceLost, StdError
from ..resource import Actuator, Driver, Sensor
from ..sample import Sample
from ..spec import Spec
from ..transport import codec, records, wire
from ..transport.codec import JSON, JSONObject

if TYPE_CHECKING:  # pragma: no cover
    from ..parts import Port
from .behavior_host import build
from ..counters import Counters
from ..plurals import counted

COMMANDS = 256

log = logging.getLogger("esair_std.resource")


#: how long a device may take to open: an emulated robot (drivers/minlink/emulated.py)
#: may itself take up to 30 s to start on a loaded machine, then the link probes it
OPEN_TIMEOUT = 40.0
#: an actuator's last commands kept for inspect (a motion, its STOP, a second STOP, ...)
LAST_OK = 4

#: a queued request's answer: ``on_done(ok, value)``, value the result, or a StdError /
#: the error's text
OnDone = Callable[[bool, Union[JSON, StdError]], None]
#: a queued request: slot, op (write | configure), its args, on_done, when it expires,
#: when it was asked (time.monotonic()), its sender
_Cmd = tuple["Slot", str, tuple[JSON, ...], OnDone, float, float, str]

class Slot:
    """One resource (a sensor or an actuator) as its host keeps it."""

    def __init__(self, host: "ResourceHost", name: str, obj: Sensor | Actuator,
                 options: dict[str, object]):
        self.host = host
        self.name = name
        self.obj = obj
        self.options = options
        self.kind = "sensor" if isinstance(obj, Sensor) else "actuator"
        self.state = "ready"
        self.reason = ""
        self.seq = 0
        self.cseq = 0                   # commands run (an actuator's record numbers)
        self.next_poll = 0.0
        self._lock = threading.Lock()
        self.c = dict(reported=0, commands=0, command_errors=0, polls_late=0)
        # an actuator's last commands that went through, [when, command, its answer]:
        # an HMI started later rebuilds the pose the robot holds from them (hmi/bridge.py)
        self.last_ok: collections.deque[list[JSON]] = collections.deque(maxlen=LAST_OK)
        self.granted: set[str] = set()
        # the command write() runs for: when it was queued and when its sender gives up
        # (time.monotonic()), so a driver can drop what it could not do in time
        self.asked: float | None = None
        self.expires: float | None = None

    def report(self, value: object) -> None:
        port = self.host.port
        encoded = getattr(port, "publish_encoded", None)
        if encoded is not None:
            # process mode: the sample is encoded once, for the wire (that is its copy);
            # data that is not JSON raises here, before it counts
            with self._lock:
                sample = Sample(cast(JSON, value), self.seq + 1, time.time(), self.name)
                data = codec.encode(sample.to_wire())
                self.seq += 1
                self.c["reported"] += 1
            encoded(self.name, data)
            return
        copied = codec.copy(value)     # thread mode: the behaviors get this very copy
        with self._lock:
            self.seq += 1
            sample = Sample(copied, self.seq, time.time(), self.name)
            self.c["reported"] += 1
        port.publish(self.name, sample)

    def count(self, key: str) -> None:
        """One more of counter ``key`` (under the lock that report() and counters() take:
        a driver's own thread reports while the host thread counts)."""
        with self._lock:
            self.c[key] = self.c.get(key, 0) + 1

    def counters(self) -> JSONObject:
        """The counters, the sample number and the state, as of one moment."""
        with self._lock:
            out: JSONObject = dict(self.c, seq=self.seq, state=self.state)
            if self.last_ok:
                out["last_ok"] = list(self.last_ok)
            return out

    def set_state(self, state: str, reason: str) -> None:
        self.state, self.reason = state, reason
        self.host.port.resource_state_changed(self.name, state, reason)


class ResourceHost:
    def __init__(self, spec: Spec, cls: type[Sensor | Actuator | Driver], port: Port):
        self.spec = spec
        self.name = spec.name
        self.cls = cls
        self.port = port
        self.options = spec.options
        self.driver: Driver | None = None
        self.slots: dict[str, Slot] = {}
        self.commands: queue.Queue[_Cmd | None] = queue.Queue(maxsize=COMMANDS)
        self._stop = threading.Event()
        self._opened = threading.Event()
        self._error: str | None = None
        self.state = "starting"
        self.reason = ""
        self.on_failed: Callable[[str], None] | None = None   # the host's thread died
        self.c = Counters(commands_refused=0, records_unsent=0, refused_stopped=0)
        # the latched STOP's refusal text while the robot is STOPPED (latch.py)
        self.halted: str | None = None
        # command records not yet published (this host's thread only) and when they are due
        self._records: list[JSON] = []
        self._records_due = 0.0
        self._rec_lock = threading.Lock()    # records also come from a STOP's thread
        self.thread = threading.Thread(target=self._main, name=f"esair:{self.name}", daemon=True)

    # ---- life cycle (called by the RS / the agent)
    def start(self, timeout: float = OPEN_TIMEOUT) -> dict[str, str]:
        """Open the device on the host thread; the children ``{name: kind}``."""
        self.thread.start()
        if not sigs.wait(self._opened, timeout):      # a SIGTERM interrupts the start
            self._stop.set()
            raise ComponentError(f"resource {self.name!r} did not open within {timeout:g} s")
        if self._error is not None:
            raise ComponentError(f"resource {self.name!r} failed to open: {self._error}")
        self.state = "ready"
        return self.children()

    def children(self) -> dict[str, str]:
        return {n: s.kind for n, s in self.slots.items()}

    def stop(self, timeout: float = 2.0) -> None:
        self._stop.set()
        try:
            self.commands.put_nowait(None)
        except queue.Full:
            pass
        if self.thread.is_alive() and threading.current_thread() is not self.thread:
            self.thread.join(timeout)
        self.state = "stopped"

    # ---- requests (any thread)
    def submit(self, resource: str, op: str, args: tuple[JSON, ...],
               on_done: OnDone, timeout: float = 1.0,
               copy: bool = True, sender: str = "") -> None:
        """Queue ``op`` (write | configure) for the host thread; ``on_done(ok, value)`` is
        called once, from the host thread (or here if it cannot be queued). ``value`` is
        the result, or a ResourceLost / the error's text. ``copy=False``: ``args`` were
        just decoded from the wire (an agent's request), so nobody else holds them and the
        wire format's copy (codec.copy: one more encode and decode) is not made again."""
        slot = self.slots.get(resource)
        if slot is None:
            return on_done(False, ResourceLost(resource, "no such resource"))
        if slot.state == "lost":
            return on_done(False, ResourceLost(
                resource, f"lost: {slot.reason}" if slot.reason else "lost"))
        if self._stop.is_set():
            return on_done(False, ResourceLost(resource, "removed"))
        if op == "write" and slot.kind != "actuator":
            return on_done(False, "is a sensor: it takes no commands")
        halted = self.halted
        if op == "write" and halted is not None:
            self.c.add("refused_stopped")
            return on_done(False, halted)
        try:
            if copy:
                args = tuple(codec.copy(a) for a in args)
            now = time.monotonic()
            self.commands.put_nowait((slot, op, args, on_done, now + timeout, now, sender))
        except queue.Full:
            self.c.add("commands_refused")
            on_done(False, "command queue full")
        except StdError as exc:
            on_done(False, exc.message)

    def _submit(self, resource: str, op: str, args: tuple[JSON, ...], timeout: float,
                sender: str = "") -> JSON:
        done = threading.Event()
        box: list[tuple[bool, JSON | StdError]] = []

        def finished(ok: bool, value: JSON | StdError) -> None:
            box.append((ok, value))
            done.set()
        self.submit(resource, op, args, finished, timeout, sender=sender)
        if not done.wait(timeout):
            raise CommandError(resource, f"no answer within {timeout:g} s")
        ok, value = box[0]
        if ok and not isinstance(value, StdError):
            return value
        raise wire.failure(value, resource)

    def command(self, sender: str, resource: str, command: JSON, timeout: float) -> JSON:
        return self._submit(resource, "write", (command,), timeout, sender)

    def configure(self, resource: str, key: str, value: JSON, timeout: float = 2.0) -> JSON:
        return self._submit(resource, "configure", (str(key), value), timeout)

    def grant(self, who: str, resource: str) -> None:
        if resource in self.slots:
            self.slots[resource].granted.add(who)

    def revoke(self, who: str, resource: str | None = None) -> None:
        for name, slot in self.slots.items():
            if resource is None or name == resource:
                slot.granted.discard(who)

    # ---- the latched STOP (latch.py; any thread)
    def halt(self, why: str) -> None:
        """STOPPED: every command refused with ``why`` from now on, those queued
        answered so at once, then the devices told to stop (Driver.halt, then each
        Actuator.halt; on this thread, not the host's, which may be inside a write)."""
        self.halted = why
        keep = []
        while True:                          # the queued writes go, their senders told
            try:
                item = self.commands.get_nowait()
            except queue.Empty:
                break
            if item is not None and item[1] == "write":
                self.c.add("refused_stopped")
                item[3](False, why)
            else:
                keep.append(item)
        for item in keep:
            try:
                self.commands.put_nowait(item)
            except queue.Full:             # new commands came meanwhile: refused anyway
                if item is not None:
                    item[3](False, "command queue full")
        stopped = False
        for obj in self._movers():
            try:
                done = obj.halt()
            except Exception as exc:  # noqa: BLE001 - the others are still stopped
                log.error("%s: halt() raised %s: %s", self.name, type(exc).__name__, exc)
                continue
            slot = getattr(obj, "_esair", None)
            if done is not None and isinstance(slot, Slot) and slot.host is self:
                # recorded as its command "stop" (recorders, the HMI's pose)
                self._ran(slot, "stop", None, {"ok": codec.copy(done)})
                stopped = True
        if stopped:
            self._publish_records()

    def release(self) -> None:
        """The STOP is released: commands are taken again; nothing is started."""
        self.halted = None
        for obj in self._movers():
            try:
                obj.release()
            except Exception as exc:  # noqa: BLE001
                log.error("%s: release() raised %s: %s", self.name, type(exc).__name__, exc)

    def _is_driver(self, obj: object) -> bool:
        """``obj`` is this entry's driver (a driver that is also its own child resource:
        it is told, opened and closed once, as the driver)."""
        return obj is self.driver

    def _movers(self) -> list[Driver | Actuator]:
        """The driver, then its actuators (those the STOP tells)."""
        out: list[Driver | Actuator] = [self.driver] if self.driver is not None else []
        return out + [s.obj for s in list(self.slots.values())
                      if s.kind == "actuator" and isinstance(s.obj, Actuator)
                      and not self._is_driver(s.obj)]

    def states(self) -> dict[str, tuple[str, str]]:
        return {n: (s.state, s.reason) for n, s in self.slots.items()}

    def counters(self) -> JSONObject:
        out: JSONObject = dict(self.c)
        for n, s in self.slots.items():
            out[n] = s.counters()
        return out

    # ---- the host thread
    def _open(self) -> None:
        obj: Sensor | Actuator | Driver = build(self.cls, self)
        items: list[tuple[str, object]]
        if isinstance(obj, Driver):
            self.driver = obj
            obj.open()
            kids = obj.resources()
            if not isinstance(kids, dict) or not kids:
                raise ComponentError("resources() gave no {child: Sensor|Actuator} dict")
            items = [(f"{self.name}.{k}", v) for k, v in kids.items()]
        elif isinstance(obj, (Sensor, Actuator)):
            items = [(self.name, obj)]
        else:
            raise ComponentError(f"{self.spec.class_path} is not a Sensor, Actuator or Driver")
        for name, child in items:
            if not isinstance(child, (Sensor, Actuator)):
                raise ComponentError(f"{name}: not a Sensor or Actuator")
            slot = Slot(self, name, child, self.spec.options)
            child._esair = slot
            self.slots[name] = slot
        rate = self.spec.options.get("rate_hz")
        if isinstance(obj, Sensor) and isinstance(rate, (int, float)) and rate > 0:
            obj.rate_hz = float(rate)         # the deployment's rate_hz wins
        for slot in self.slots.values():
            if not self._is_driver(slot.obj):
                slot.obj.open()

    def _main(self) -> None:
        try:
            self._open()
        except Exception as exc:  # noqa: BLE001 - the user's open() failed
            self._error = f"{type(exc).__name__}: {exc}"
            self._opened.set()
            self._close()
            return
        self._opened.set()
        now = time.monotonic()
        for s in self.slots.values():
            s.next_poll = now
        try:
            self._serve()
        except BaseException as exc:  # noqa: BLE001 - the host dies: its supervisor decides
            self._died(f"{type(exc).__name__}: {exc}")
            return
        self._close()

    def _serve(self) -> None:
        while not self._stop.is_set():
            wait = self._poll()
            if self._records:
                wait = min(wait, max(0.0, self._records_due - time.monotonic()))
            try:
                item = self.commands.get(timeout=wait)
            except queue.Empty:
                item = ()
            if item is None:
                break
            if item:
                self._run(*item)
            if self._records and time.monotonic() >= self._records_due:
                self._publish_records()

    def _died(self, reason: str) -> None:
        """The host's thread ends without being asked (a user call raised past every
        handler, e.g. SystemExit): the entry is failed, its supervisor restarts it."""
        self.state, self.reason = "failed", f"its host died: {reason}"
        log.error("%s: %s", self.name, self.reason)
        for s in self.slots.values():
            s.state, s.reason = "lost", self.reason
        while True:                       # nothing queued is carried out any more
            try:
                item = self.commands.get_nowait()
            except queue.Empty:
                break
            if item is not None:
                item[3](False, ResourceLost(item[0].name, self.reason))
        try:
            self._close()
        except BaseException as exc:  # noqa: BLE001
            log.warning("%s: close after failure: %s", self.name, exc)
        if self.on_failed is not None and not self._stop.is_set():
            self.on_failed(self.reason)

    def _poll(self) -> float:
        """Read the sensors that are due; seconds until the next one is."""
        wait = 0.5
        now = time.monotonic()
        for s in self.slots.values():
            rate = getattr(s.obj, "rate_hz", None) if s.kind == "sensor" else None
            if not rate or s.state == "lost":
                continue
            if now >= s.next_poll:
                try:
                    value = cast(Sensor, s.obj).read()     # a sensor's slot (rate above)
                    if value is not None:
                        s.report(value)
                except Exception as exc:  # noqa: BLE001 - a failing read loses the device
                    s.set_state("lost", f"read() raised {type(exc).__name__}: {exc}")
                    continue
                s.next_poll += 1.0 / float(rate)
                now = time.monotonic()
                if s.next_poll < now:
                    s.count("polls_late")
                    s.next_poll = now + 1.0 / float(rate)
            wait = min(wait, max(0.0, s.next_poll - now))
        return wait

    def _run(self, slot: Slot, op: str, args: tuple[JSON, ...], on_done: OnDone, expires: float,
             asked: float | None = None, sender: str = "") -> None:
        if time.monotonic() > expires:       # the sender gave up: do not act late
            slot.count("expired")
            return on_done(False, "expired in the queue")
        if op == "write" and self.halted is not None:     # STOPPED while it waited
            self.c.add("refused_stopped")
            return on_done(False, self.halted)
        try:
            if slot.state == "lost":
                raise ResourceLost(slot.name, f"lost: {slot.reason}" if slot.reason else "lost")
            if op == "write":
                slot.count("commands")
                slot.asked, slot.expires = asked, expires
                # submit() queues writes for actuators only, as (command,)
                value = codec.copy(cast(Actuator, slot.obj).write(*args))
            else:
                value = codec.copy(slot.obj.configure(*cast("tuple[str, JSON]", args)))
        except ResourceLost as exc:
            on_done(False, exc)
            if op == "write":
                self._ran(slot, args[0], asked, {"error": exc.reason}, sender)
            return None
        except CommandError as exc:
            slot.count("command_errors")
            why = exc.reason
            if op == "write" and self.halted is not None:
                why = self.halted              # STOPPED while it ran: the STOP's words
            on_done(False, why)
            if op == "write":
                self._ran(slot, args[0], asked, {"error": why}, sender)
            return None
        except Exception as exc:  # noqa: BLE001 - reaches the sender as CommandError
            slot.count("command_errors")
            on_done(False, f"{type(exc).__name__}: {exc}")
            if op == "write":
                self._ran(slot, args[0], asked, {"error": f"{type(exc).__name__}: {exc}"}, sender)
            return None
        except BaseException as exc:
            on_done(False, ResourceLost(slot.name, f"its host died: {type(exc).__name__}: {exc}"))
            raise
        on_done(True, value)
        if op == "write":
            self._ran(slot, args[0], asked, {"ok": value}, sender)

    def _ran(self, slot: Slot, command: JSON, asked: float | None, outcome: JSONObject,
             sender: str = "") -> None:
        """A command the actuator ran and its outcome, for recorders (after its sender has
        its answer): ``{r, seq, t, v: {command, ok | error, by}}``, ``seq`` the actuator's
        command number, ``t`` when it reached this host (time.time()), ``by`` its sender
        (left out when the host itself ran it: a STOP's halt). Published with the
        others of this entry in one message, at most records.BATCH_S after the first
        (transport/records.py)."""
        with self._rec_lock:
            slot.cseq += 1
            now = time.time()
            t = now if asked is None else now - (time.monotonic() - asked)
            if not self._records:
                self._records_due = time.monotonic() + records.BATCH_S
            self._records.append(records.record(slot.name, slot.cseq, t,
                                                dict(outcome, by=sender) if sender else outcome,
                                                command))
            full = len(self._records) >= records.BATCH_MAX
        if "ok" in outcome:
            with slot._lock:
                slot.last_ok.append([t, command, outcome["ok"]])
        if full:
            self._publish_records()

    def _publish_records(self) -> None:
        with self._rec_lock:
            batch, self._records = self._records, []
        if not batch:
            return
        try:
            self.port.publish_commands(self.name, batch)
        except Exception as exc:  # noqa: BLE001 - a record lost is not the command's fault
            log.warning("%s: %s not published: %s", self.name,
                        counted(len(batch), "command record"), exc)
            self.c.add("records_unsent", len(batch))

    def _close(self) -> None:
        if self._records:                 # what the last commands ran goes out
            self._publish_records()
        for s in self.slots.values():
            if not self._is_driver(s.obj):
                try:
                    s.obj.close()
                except Exception as exc:  # noqa: BLE001
                    log.warning("%s: close() raised %s", s.name, exc)
        if self.driver is not None:
            try:
                self.driver.close()
            except Exception as exc:  # noqa: BLE001
                log.warning("%s: close() raised %s", self.name, exc)
