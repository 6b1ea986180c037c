"""Components the STD tests deploy (imported by the runtime and by agent processes)."""

from __future__ import annotations

import os
import time
from pathlib import Path

from esair_std import Actuator, Behavior, CommandError, Driver, Reaction, ResourceLost, Sensor
from esair_std.drivers.sim import Counter as SimCounter


class Counter(SimCounter):
    """The shipped counter (1, 2, 3...) at option ``rate`` Hz, 200 by default."""

    def open(self):
        super().open()
        self.rate_hz = float(self.options.get("rate", 200))


class Recorder(Actuator):
    """Keeps the commands; ``{"fail": msg}`` raises ValueError, ``{"refuse": msg}``
    CommandError; ``{"lost": why}`` marks it lost. ``gain`` is configurable."""
    settings = ("gain",)

    def open(self):
        self.log_ = []
        self.gain = 1

    def write(self, command):
        if isinstance(command, dict) and "fail" in command:
            raise ValueError(command["fail"])
        if isinstance(command, dict) and "refuse" in command:
            raise CommandError(self.name, command["refuse"])
        if isinstance(command, dict) and "lost" in command:
            self.mark_lost(command["lost"])
            return "marking lost"
        if isinstance(command, dict) and "die" in command:
            raise SystemExit(command["die"])      # past every handler: the host dies
        self.log_.append(command)
        return {"n": len(self.log_), "gain": self.gain}

    def configure(self, key, value):
        if key == "gain":
            self.gain = value
            return value
        return super().configure(key, value)


class BadOpen(Sensor):
    def open(self):
        raise OSError("no such device /dev/nothing")


class GatedOpen(Sensor):
    """Opens once the file ``options['gate']`` exists (at most ``options['limit']``
    seconds, 60 by default): a runtime held in its start, its behaviors not added yet."""

    def open(self):
        gate = Path(self.options["gate"])
        end = time.monotonic() + float(self.options.get("limit", 60))
        while not gate.exists() and time.monotonic() < end:
            time.sleep(0.02)


class Pair(Driver):
    """A driver with two children: ``<entry>.count`` (sensor) and ``<entry>.rec``."""

    def resources(self):
        return {"count": Counter(), "rec": Recorder()}


class Sink(Behavior):
    """Takes puts; provide() gives what it received (sender, data) so far."""

    def start(self):
        self.got = []

    def receive(self, sender, data):
        self.got.append([sender, data])

    def provide(self, requester):
        return {"got": self.got, "pid": os.getpid()}


class Watcher(Behavior):
    """Attaches to the sensor named in options['sensor'] and keeps every seq it saw;
    provide() reports them compactly (count, first, last, gaps)."""

    period = 0.01

    def start(self):
        self.h = self.attach_sensor(self.options.get("sensor", "count"),
                                    keep=int(self.options.get("keep", 4096)))
        self.seqs = []
        self.detach_notices = []

    def step(self):
        if self.options.get("slow"):
            time.sleep(float(self.options["slow"]))
        self.seqs.extend(s.seq for s in self.h.samples())

    def detached(self, resource):
        self.detach_notices.append(resource)

    def provide(self, requester):
        s = self.seqs
        gaps = sum(1 for a, b in zip(s, s[1:]) if b != a + 1)
        return {"n": len(s), "first": s[0] if s else None, "last": s[-1] if s else None,
                "gaps": gaps, "overwritten": self.h.overwritten, "state": self.h.state,
                "notices": self.detach_notices,
                # the samples numbered between two it read but never read, and the
                # handle's count of those that never reached it
                "unread": sum(b - a - 1 for a, b in zip(s, s[1:]) if b > a + 1),
                "missed": self.h.missed}


class Pusher(Behavior):
    """Puts a numbered message to options['to'] every step; provide() gives its tally."""

    period = 0.01

    def start(self):
        self.n = 0
        self.ok = 0
        self.failed = 0

    def step(self):
        self.n += 1
        if self.put(self.options.get("to", "sink"), {"n": self.n}, timeout=0.5):
            self.ok += 1
        else:
            self.failed += 1

    def provide(self, requester):
        return {"n": self.n, "ok": self.ok, "failed": self.failed}


class Faulty(Behavior):
    """Fails on demand: option 'fail' = 'raise' | 'hang' | 'start'; runs otherwise."""

    period = 0.01

    def start(self):
        if self.options.get("fail") == "start":
            raise RuntimeError("refuses to start")
        self.steps = 0

    def step(self):
        self.steps += 1
        if self.steps == 3 and self.options.get("fail") == "raise":
            raise RuntimeError("boom")
        if self.steps == 3 and self.options.get("fail") == "hang":
            time.sleep(3.0)

    def receive(self, sender, data):
        if data == "raise":
            raise RuntimeError("told to raise")

    def provide(self, requester):
        return {"pid": os.getpid(), "steps": self.steps}


class Commander(Behavior):
    """Attaches to options['actuator'] (level per options['level'], default command)."""

    def start(self):
        self.act = self.attach_actuator(self.options.get("actuator", "rec"))

    def receive(self, sender, data):
        pass

    def provide(self, requester):
        try:
            return {"ok": self.act.send({"angle": 1}), "state": self.act.state}
        except Exception as exc:  # noqa: BLE001
            return {"error": type(exc).__name__, "message": str(exc), "state": self.act.state}


class Guard(Reaction):
    """Watches 'count', commands 'rec' when the count passes a multiple of 10."""

    period = 0.01

    def start(self):
        self.count = self.resource("count")
        self.rec = self.resource("rec")
        self.fired = 0

    def step(self):
        for s in self.count.samples():
            if s.seq % 10 == 0:
                self.rec.send({"guard": s.seq})
                self.fired += 1


class Probe(Behavior):
    """Runs one API call per request: put it {"do": method, "args": [...]}, then get()
    the outcome {"ok": result} or {"error": ExceptionType, "message": str}."""

    def start(self):
        self.todo = None
        self.handles = {}
        self.notices = []

    def receive(self, sender, data):
        self.todo = data

    def detached(self, resource):
        self.notices.append(resource)

    def provide(self, requester):
        todo, self.todo = self.todo, None
        if todo is None:
            return {"notices": self.notices}
        do, args = todo["do"], todo.get("args", [])
        try:
            if do == "send":
                out = self.handles[args[0]].send(*args[1:])
            elif do == "send_set":                  # a command that is not JSON
                out = self.handles[args[0]].send({1, 2})
            elif do == "handle_state":
                out = self.handles[args[0]].state
            elif do == "latest":
                s = self.handles[args[0]].latest()
                out = None if s is None else [s.seq, s.value, s.source]
            elif do == "stamp":                     # the newest sample's number and time
                s = self.handles[args[0]].latest()
                out = None if s is None else [s.seq, s.t]
            else:
                out = getattr(self, do)(*args)
                if do in ("attach_sensor", "attach_actuator"):
                    self.handles[args[0]] = out
                    out = out.state
        except Exception as exc:  # noqa: BLE001
            return {"error": type(exc).__name__, "message": str(exc)}
        return {"ok": out}


class BusyRun(Behavior):
    """run() that lasts until the behavior is stopped: busy all along."""

    def run(self):
        while not self.stopping:
            time.sleep(0.005)


class RunOnce(Behavior):
    def run(self):
        self.ran = 1

    def provide(self, requester):
        return {"ran": self.ran}


class SlowSink(Sink):
    """A Sink whose receive() takes ``options.ms`` milliseconds: its mailbox fills."""

    def receive(self, sender, data):
        time.sleep(float(self.options.get("ms", 3)) / 1000)
        super().receive(sender, data)


class Burst(Behavior):
    """run(): ``options.n`` puts to ``options.to`` as fast as they go (timeout 5 s);
    provide() gives each put's outcome, in order."""

    def run(self):
        to, n = self.options["to"], int(self.options["n"])
        self.ok = [self.put(to, {"i": i}, timeout=5.0) for i in range(n)]

    def provide(self, requester):
        return {"ok": self.ok}


class Gate(Behavior):
    """Makes itself busy on a put of "close"; free again once the file
    ``options.release`` exists (the test decides when, not a wall-clock hold)."""

    period = 0.01

    def start(self):
        self.got, self.closed = [], False

    def receive(self, sender, data):
        self.got.append(data)
        if data == "close":
            self.busy = self.closed = True

    def step(self):
        if self.closed and os.path.exists(self.options["release"]):
            self.busy = self.closed = False

    def provide(self, requester):
        return {"got": self.got}


class Tally(Actuator):
    """Counts the steps' commands per tag and records every stop() (configure "log")."""

    def open(self):
        self.steps = {}
        self.stopped = []

    def write(self, command):
        if "stopped" in command:
            self.stopped.append(command["stopped"])
        else:
            self.steps[str(command["step"])] = self.steps.get(str(command["step"]), 0) + 1
        return None

    def configure(self, key, value):
        return {"steps": self.steps, "stopped": self.stopped}


class StreamStepper(Behavior):
    """Reads the sensor and commands ``tally`` every step; its stop() commands it once."""

    def start(self):
        self.h = self.attach_sensor("count")
        self.act = self.attach_actuator("tally")
        self.tag = self.options["tag"]

    def step(self):
        self.h.samples()
        self.act.send({"step": self.tag})

    def stop(self):
        self.act.send({"stopped": self.tag})


class Eager(Behavior):
    """Attaches options['actuator'] in start() and commands it at once."""

    def start(self):
        self.act = self.attach_actuator(self.options.get("actuator", "rec"))
        self.first = self.act.send({"eager": 1})

    def provide(self, requester):
        return {"first": self.first}


class Steady(Behavior):
    """Every step commands options['actuator'] with timeout options['timeout'] (and/or
    puts to options['to']); counts what failed. Its deadline (option) is tight."""

    period = 0.1

    def start(self):
        self.act = self.attach_actuator(self.options.get("actuator", "rec"))
        self.sent = self.failed = 0

    def step(self):
        try:
            self.act.send({"n": self.sent}, timeout=float(self.options["timeout"]))
            self.sent += 1
        except (CommandError, ResourceLost):
            self.failed += 1

    def provide(self, requester):
        return {"sent": self.sent, "failed": self.failed}


class SteadyPut(Behavior):
    """Every step puts to options['to'] with timeout options['timeout']; counts."""

    period = 0.1

    def start(self):
        self.ok = self.failed = 0

    def step(self):
        if self.put(self.options["to"], {"n": self.ok}, timeout=float(self.options["timeout"])):
            self.ok += 1
        else:
            self.failed += 1

    def provide(self, requester):
        return {"ok": self.ok, "failed": self.failed}


class GatedRecorder(Recorder):
    """A Recorder whose write() first appends the command to the file ``options.entered``
    and then waits for one byte on the FIFO ``options.gate``: the test decides when each
    write ends. Opened read-write, so the FIFO neither blocks open() nor reads as closed."""

    def open(self):
        super().open()
        self._gate = os.open(self.options["gate"], os.O_RDWR)

    def write(self, command):
        with open(self.options["entered"], "a") as f:
            f.write(f"{command}\n")
        os.read(self._gate, 1)
        return super().write(command)

    def close(self):
        if self.options.get("close_waits"):          # close() too waits for its byte
            with open(self.options["entered"], "a") as f:
                f.write("closing\n")
            os.read(self._gate, 1)
        os.close(self._gate)
        with open(self.options["entered"], "a") as f:
            f.write("closed\n")
        if "close_raises" in self.options:
            raise OSError(self.options["close_raises"])
        if "close_exits" in self.options:           # past every handler, as a stuck driver
            raise SystemExit(self.options["close_exits"])


class ClosingPair(Pair):
    """A Pair whose close() appends "closed" to the file ``options.closed``, then raises."""

    def close(self):
        with open(self.options["closed"], "a") as f:
            f.write("closed\n")
        raise OSError("bus error")


class GatedSink(Sink):
    """A Sink whose receive() waits until the file ``options.release`` exists: its
    mailbox fills and stays full until the test opens the gate. Keeps each put's ``i``
    only (its padding makes it big enough to be a plain offer in process mode)."""

    def receive(self, sender, data):
        while not os.path.exists(self.options["release"]) and not self.stopping:
            time.sleep(0.01)
        super().receive(sender, {"i": data["i"]})
