"""PAPA-MAN's host behaviors (docs/std-papaman.md; thesis ch. 5.2 operations).

- ``Sequencer`` plays the operations it is given (``esair std put sequencer
  '["stand_up", "dance"]'``) one after another on ``papaman.motion``; when the link is
  lost, or the robot is STOPPED (docs/std.md, "The latched stop"), it drops what it
  has queued, reporting each dropped operation (its ``dropped`` and ``errors``, and a
  warning in the log): nothing asked before an outage or a STOP is played after it;
- ``BalanceWatcher`` reads the feet at 50 Hz and, when the load shifts from one foot to
  the other, stops the motion and stands the robot up (beside the firmware's own
  auto-balance reaction, whose ``!R`` notices it counts);
- ``Logger`` ``get``s the others' state twice a second and keeps the last records.
"""

from __future__ import annotations

import collections
import time

from esair_std import Behavior, CommandError, Refused, ResourceLost
from esair_std.transport.codec import JSON, JSONObject

#: thesis ch. 5.2 operations -> the robot's motions (boards/papaman/central.yaml)
OPERATIONS = {"stand_up": "stand", "sit_down": "sit", "prostrate": "prostrate",
              "dance": "dance", "auto_balance": "balance"}
QUEUE = 32          # operations waiting; more are refused (counted)
TICK_S = 0.0089856  # PAPA-MAN's Timer2 tick
MARGIN_TICKS = 3
STAND_RETRY_S = 1.0  # the watcher's stand, while the robot is busy
OPERATION_DEADLINE_S = 5.0  # a queued operation not started by then is dropped (option
                            # operation_deadline; "deadline" is the step watchdog's)
SEND_TIMEOUT_S = 0.3  # each command's send timeout: written within it, or dropped; well
                      # inside the 1 s step deadline, also in process mode
#: frames x delay_ticks of each motion (central.yaml): how long it plays
MOTION_TICKS = {"stand": 1 * 10, "sit": 3 * 20, "prostrate": 4 * 25, "dance": 32 * 1,
                "balance": 3 * 2}


def _last_stop(ops: list) -> int:
    """The index of the last "stop" in ``ops`` (-1: none)."""
    return max((i for i, op in enumerate(ops) if op == "stop"), default=-1)


class Sequencer(Behavior):
    """Plays queued operations in order; E07 busy means "not yet": tried again until the
    operation's deadline (option ``operation_deadline``, seconds from its arrival; default
    5). An operation
    that cannot start by then, or that is queued when the link is lost, is dropped and
    reported."""

    def start(self) -> None:
        self.motion = self.attach_actuator("papaman.motion")
        self.queue: collections.deque[tuple[str, float]] = collections.deque()
        self.playing: str | None = None
        self.until = 0.0
        self.done: list[str] = []
        self.refused = 0
        self.dropped: list[str] = []
        self.errors: list[str] = []
        self.operation_deadline = float(self.options.get("operation_deadline", OPERATION_DEADLINE_S))

    def receive(self, sender: str, data: object) -> None:
        """Queue the operations, all or none: raising Refused tells a sender that waits
        (`esair std put`) why, and the sequencer runs on."""
        ops = [data] if isinstance(data, str) else data
        if not isinstance(ops, list):
            self.refused += 1
            raise Refused(f"expected an operation or a list of them, got {data!r}")
        unknown = [op for op in ops if op != "stop" and op not in OPERATIONS]
        if unknown:
            self.refused += 1
            raise Refused(f"unknown operation {unknown[0]!r} (known: stop, "
                          f"{', '.join(OPERATIONS)}); nothing queued")
        queued = ops[_last_stop(ops) + 1:]
        if len(self.queue) + len(queued) > QUEUE and "stop" not in ops:
            self.refused += 1
            raise Refused(f"the queue holds {len(self.queue)} of {QUEUE} operations: no room "
                          f"for {len(queued)} more; nothing queued")
        now = time.monotonic()
        for op in ops:
            if op == "stop":
                self._drop("stopped")
                self._send("stop", "stop")
            elif len(self.queue) < QUEUE:
                self.queue.append((op, now + self.operation_deadline))

    def step(self) -> None:
        now = time.monotonic()
        if self.queue and (state := self.motion.state) != "ready":
            self._drop(f"papaman.motion is {state}")      # the link is lost: none waits
        if self.playing is not None and now >= self.until:
            self.done.append(self.playing)
            self.playing = None
        while self.queue and self.queue[0][1] < now:
            op, _ = self.queue.popleft()
            self._dropped(op, f"not started within its {self.operation_deadline:g} s deadline")
        if self.playing is None and self.queue:
            op = self.queue[0][0]
            motion = OPERATIONS[op]
            if self._send(op, {"play": motion}):
                self.queue.popleft()
                # the first frame is written at the tick after the reply; a margin of
                # ticks for the robot's clock against this one
                ticks = MOTION_TICKS[motion] + 1 + MARGIN_TICKS
                self.playing, self.until = op, now + ticks * TICK_S

    def _send(self, op: str, command: JSON) -> bool:
        try:
            self.motion.send(command, timeout=SEND_TIMEOUT_S)
            return True
        except CommandError as exc:
            if "E07 busy" not in str(exc):      # busy: the robot is still moving
                self.errors.append(f"{op}: {exc}")
                self._drop(f"{op} failed")
        except ResourceLost as exc:
            self.errors.append(f"{op}: {exc}")
            self._drop(f"the link is lost ({exc})")
        return False

    def robot_stopped(self, by: str, reason: str) -> None:
        """The robot was STOPPED: nothing queued plays on after the release."""
        if self.playing is not None:
            self.errors.append(f"{self.playing}: cut by the STOP")
            self.playing = None
        self._drop(f"the robot was STOPPED by {by}")

    def _drop(self, why: str) -> None:
        """Drop every queued operation, each one reported."""
        while self.queue:
            op, _ = self.queue.popleft()
            self._dropped(op, why)

    def _dropped(self, op: str, why: str) -> None:
        self.dropped.append(op)
        self.errors.append(f"{op}: dropped: {why}")
        self.log.warning("operation %r dropped: %s", op, why)

    def provide(self, requester: str) -> JSON:
        return {"playing": self.playing, "queued": [op for op, _ in self.queue],
                "done": list(self.done[-20:]), "refused": self.refused,
                "dropped": list(self.dropped[-20:]), "dropped_total": len(self.dropped),
                "errors": list(self.errors[-5:])}


class BalanceWatcher(Behavior):
    """Stops the motion and stands up when the feet's load shifts (host side)."""

    def start(self) -> None:
        self.feet = self.attach_sensor("papaman.feet", keep=8)
        self.notices = self.attach_sensor("papaman.notices", keep=64)
        self.motion = self.attach_actuator("papaman.motion")
        self.threshold = int(self.options.get("threshold", 400))
        self.need = int(self.options.get("samples", 2))
        self.tipping = 0
        self.reactions: list[dict] = []
        self.firmware = 0
        self.samples = 0
        self.ages: collections.deque[float] = collections.deque(maxlen=1000)
        self.errors: list[str] = []
        self.standing: tuple[dict, float] | None = None

    def step(self) -> None:
        if self.standing is not None and (state := self.motion.state) != "ready":
            record, _ = self.standing           # the link is lost: no stand after it
            self.standing = None
            self.errors.append(f"stand after the reaction at seq {record['seq']}: dropped: "
                               f"papaman.motion is {state}")
        if self.standing is not None:
            self._stand()
        for n in self.notices.samples():
            if n.value.get("notice", "").startswith("R "):
                self.firmware += 1
        fresh = self.feet.samples()
        if not fresh:
            return
        self.ages.append(time.time() - fresh[-1].t)     # the newest sample's age, now
        for s in fresh:
            self.samples += 1
            groups = list(s.value["groups"].values())
            shift = abs(groups[0] - groups[1]) if len(groups) == 2 else 0
            self.tipping = self.tipping + 1 if shift > self.threshold else 0
            if self.tipping >= self.need:
                self.tipping = 0
                self._react(shift, s.seq)

    def robot_stopped(self, by: str, reason: str) -> None:
        self.standing = None           # no stand after the STOP's release

    def _react(self, shift: int, seq: int) -> None:
        record = {"shift": shift, "seq": seq, "sent": [], "t": time.time()}
        self.reactions.append(record)
        if self._send("stop", record):
            self.standing = (record, time.monotonic() + STAND_RETRY_S)
            self._stand()

    def _stand(self) -> None:
        """Stand up; while the robot is busy (the firmware's own balance motion playing,
        E07) try again each step for STAND_RETRY_S."""
        if self.standing is None:             # called only while standing up
            return
        record, until = self.standing
        if self._send("stand", record, busy_ok=True) is not None or time.monotonic() > until:
            self.standing = None

    def _send(self, command: str, record: dict, busy_ok: bool = False) -> bool | None:
        """True: sent; False: failed (kept in errors); None: busy, to be tried again."""
        try:
            sent = self.motion.send(command, timeout=SEND_TIMEOUT_S)
            # the line sent (a stop's answer also says when the robot had it: {"line", "at"})
            record["sent"].append(sent["line"] if isinstance(sent, dict) else sent)
            return True
        except CommandError as exc:
            if busy_ok and "E07 busy" in str(exc):
                return None
            self.errors.append(str(exc))
        except ResourceLost as exc:
            self.errors.append(str(exc))
        return False

    def provide(self, requester: str) -> JSON:
        ages = sorted(self.ages)
        return {"reactions": list(self.reactions[-10:]), "firmware_reactions": self.firmware,
                "samples": self.samples, "errors": list(self.errors[-5:]),
                "age_p50_ms": ages[len(ages) // 2] * 1e3 if ages else None,
                "age_p99_ms": ages[int(len(ages) * 0.99)] * 1e3 if ages else None}


class Logger(Behavior):
    """Gets the sequencer's and the watcher's state; keeps the last ``keep`` records."""

    def start(self) -> None:
        self.records: collections.deque[JSON] = collections.deque(
            maxlen=int(self.options.get("keep", 100)))
        self.failed = 0

    def step(self) -> None:
        record: JSONObject = {"t": time.time()}
        for name in ("sequencer", "watcher"):
            value = self.get(name, timeout=0.2)
            if value is None:
                self.failed += 1
            record[name] = value
        self.records.append(record)
        self.log.info("%s", record)

    def provide(self, requester: str) -> JSON:
        return {"records": list(self.records)[-5:], "failed": self.failed}
