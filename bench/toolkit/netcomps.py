"""Components of the many-computer tests and benches, deployed by class path
``bench.toolkit.netcomps:NAME`` (the checkout is on the control center's and the remote
agents' PYTHONPATH: netstd.env)."""

from __future__ import annotations

from esair_std import Actuator, Behavior, CommandError, Refused, ResourceLost
from esair_std.drivers.sim import Counter as SimCounter


class Counter(SimCounter):
    """The shipped counter (1, 2, 3...) at option ``rate`` Hz, 200 by default."""

    def open(self):
        super().open()
        self.rate_hz = float(self.options.get("rate", 200))


class Wheel(Actuator):
    """Keeps the commands; answers how many it has."""

    def open(self):
        self.got = []

    def write(self, command):
        self.got.append(command)
        return {"n": len(self.got), "last": command}


class Pusher(Behavior):
    """Commands actuator ``arm`` every step (each send gives up after ``timeout``, default
    0.6 s: the docs' advice for a 1 s step; 0.2 s was too short for a loaded CI machine
    across the veth); provide(): the actuator's last answer and what went wrong (for a `read`
    registration: the refusal) with how many sends failed in all."""

    period = 0.05

    def start(self):
        self.last, self.errors, self.sent, self.failed = None, [], 0, 0
        try:
            self.arm = self.attach_actuator(self.options.get("actuator", "arm"))
        except (Refused, CommandError) as exc:
            self.arm = None
            self.errors.append(str(exc))

    def step(self):
        if self.arm is None:
            return
        self.sent += 1
        try:
            # well inside the step deadline (1 s): a partition must not make it hang
            self.last = self.arm.send({"push": self.sent},
                                      timeout=float(self.options.get("timeout", 0.6)))
        except (CommandError, ResourceLost, Refused) as exc:
            self.failed += 1
            self.errors = (self.errors + [str(exc)])[-5:]

    def provide(self, requester):
        return {"last": self.last, "sent": self.sent, "errors": self.errors,
                "failed": self.failed}


class Locate(Behavior):
    """STARFISH's remote audio locator: from the local sensor ``mic`` a heading for the
    local behavior ``turn`` (put through the BS)."""

    period = 0.02

    def start(self):
        self.mic = self.attach_sensor("mic")
        self.sent = 0

    def step(self):
        s = self.mic.latest()
        if s is not None and s.seq != getattr(self, "_seen", None):
            self._seen = s.seq
            to = self.options.get("to", "turn")          # "b/turn": robot b's behavior
            if self.put(to, {"heading": (s.value * 7) % 360, "seq": s.seq}, 0.5):
                self.sent += 1

    def provide(self, requester):
        return {"sent": self.sent}


class Turn(Behavior):
    """Takes headings (put by locate) and steers the local actuator ``wheel``."""

    def start(self):
        self.headings = []
        self.wheel = self.attach_actuator("wheel")

    def receive(self, sender, data):
        self.headings.append([sender, data])
        self.headings = self.headings[-200:]
        self.wheel.send({"turn": data["heading"]}, timeout=1.0)

    def provide(self, requester):
        return self.headings


class Watch(Behavior):
    """Reads the (remote) sensor ``ticks``; provide(): every sequence number seen."""

    period = 0.01

    def start(self):
        self.ticks = self.attach_sensor("ticks", keep=512)
        self.seqs = []

    def step(self):
        for s in self.ticks.samples():
            self.seqs.append(s.seq)

    def provide(self, requester):
        return {"seqs": self.seqs, "overwritten": self.ticks.overwritten}


class Idle(Behavior):
    """A local behavior that only counts its steps (it must go on through partitions)."""

    period = 0.01

    def start(self):
        self.steps = 0

    def step(self):
        self.steps += 1

    def provide(self, requester):
        return self.steps


class Sink(Behavior):
    """Takes every put at once; provide(): how many from whom."""

    def start(self):
        self.senders = {}

    def receive(self, sender, data):
        self.senders[sender] = self.senders.get(sender, 0) + 1

    def provide(self, requester):
        return self.senders


class Putter(Behavior):
    """A local behavior that puts to the local ``sink`` every step (1 s timeout);
    provide(): how many puts were delivered and how many failed."""

    period = 0.05

    def start(self):
        self.ok = self.failed = 0

    def step(self):
        if self.put("sink", {"n": self.ok}, timeout=1.0):
            self.ok += 1
        else:
            self.failed += 1

    def provide(self, requester):
        return {"ok": self.ok, "failed": self.failed}


class PutBench(Behavior):
    """bench/std_net.py: ``n`` puts to ``to`` one after the other; provide(): the round
    trips (seconds), and the registration time of one actuator and one sensor."""

    def run(self):
        import time
        t0 = time.perf_counter()
        if self.options.get("actuator"):
            self.attach_actuator(self.options["actuator"])
        t1 = time.perf_counter()
        self.register_s = t1 - t0
        self.times, self.failed = [], 0
        for i in range(int(self.options.get("n", 1000))):
            t = time.perf_counter()
            if self.put(self.options.get("to", "sink"), {"i": i}, 1.0):
                self.times.append(time.perf_counter() - t)
            else:
                self.failed += 1
        self.done = True

    def provide(self, requester):
        if not getattr(self, "done", False):
            return None
        return {"times": self.times, "failed": self.failed, "register_s": self.register_s}


class StreamStats(Behavior):
    """bench/std_net.py: counts a sensor's samples by sequence number, with the arrival
    time (time.time()) of the first sample after each hole."""

    period = 0.005

    def start(self):
        import time
        self._time = time.time
        self.h = self.attach_sensor(self.options.get("sensor", "ticks"), keep=4096)
        self.count, self.first, self.last, self.holes = 0, None, None, []

    def step(self):
        now = self._time()
        for s in self.h.samples():
            if self.last is not None and s.seq != self.last + 1:
                self.holes.append([self.last, s.seq, now])
            if self.first is None:
                self.first = s.seq
            self.last = s.seq
            self.count += 1

    def provide(self, requester):
        return {"count": self.count, "first": self.first, "last": self.last,
                "holes": self.holes, "overwritten": self.h.overwritten}


class Strict(Behavior):
    """Commands actuator ``arm`` every step and does not catch a failure: a cut link
    fails it (its send gives up after 0.2 s). provide(): its steps since it (re)started."""

    period = 0.05

    def start(self):
        self.steps = 0
        self.arm = self.attach_actuator("arm")

    def step(self):
        self.steps += 1
        self.arm.send({"push": self.steps}, timeout=0.2)

    def provide(self, requester):
        return {"steps": self.steps}


class Timely(Behavior):
    """Follows the docs: its calls' timeouts (0.6 s) fit its step deadline (1 s). Steps
    alternately command ``arm`` and put to ``sink``; provide(): what came of them."""

    period = 0.05

    def start(self):
        self.arm = self.attach_actuator("arm")
        self.c = {"steps": 0, "sent": 0, "send_failed": 0, "put": 0, "put_failed": 0}

    def step(self):
        self.c["steps"] += 1
        if self.c["steps"] % 2:
            try:
                self.arm.send({"push": self.c["steps"]}, timeout=0.6)
                self.c["sent"] += 1
            except (CommandError, ResourceLost):
                self.c["send_failed"] += 1
        elif self.put("sink", {"n": self.c["steps"]}, timeout=0.6):
            self.c["put"] += 1
        else:
            self.c["put_failed"] += 1

    def provide(self, requester):
        return dict(self.c)
