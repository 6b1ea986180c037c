"""The resource host by itself (esair_std/hosts/resource_host.py): its command path, its
open and its life, its sensor poll under a clock the test moves, with a port that keeps
what it reports. Each test fails when its rule breaks."""

from __future__ import annotations

import threading
import time

import pytest

from esair_std import Actuator, Driver, Sensor
from esair_std.errors import ComponentError
from esair_std.errors import CommandError, ResourceLost, StdError
from esair_std.hosts import resource_host as reshost
from esair_std.hosts.resource_host import ResourceHost
from esair_std.spec import Spec as ResourceSpec
from tests.support.std import logged, wait_for


# ---- the resource host by itself -------------------------------------------------------
# The host runs without a runtime: a HostPort that keeps what the host reports (its
# samples, its command records, its resources' states) stands for the RS and the SC; the
# actuator Held waits on a semaphore the test releases, so what is queued behind a
# command, and when it runs, is decided by the test. The sensor poll is driven by hand
# with a clock the test moves, as the supervisor's tests do.


class HostPort:
    """What the host reports: samples, command records and state changes, in order."""

    def __init__(self, fail_records: str | None = None):
        self.samples: list[tuple] = []
        self.records: list[tuple] = []
        self.batches: list[tuple] = []        # (entry, records in it)
        self.states: list[tuple] = []
        self.fail_records = fail_records

    def publish(self, resource, sample):
        self.samples.append((resource, sample.seq, sample.value, sample.source))

    def publish_commands(self, entry, batch):
        if self.fail_records:
            raise OSError(self.fail_records)
        self.batches.append((entry, len(batch)))
        self.records += [(r["r"], {k: r[k] for k in ("seq", "t", "v")}) for r in batch]

    def resource_state_changed(self, resource, state, reason):
        self.states.append((resource, state, reason))


def host_of(cls: type, name: str = "arm", port: HostPort | None = None, **options) -> ResourceHost:
    return ResourceHost(ResourceSpec("resource", name, f"{__name__}:{cls.__name__}", options), cls,
                        port or HostPort())


class Held(Actuator):
    """write(command) notes the command in ``options["entered"]``, then waits for one
    release of the semaphore ``options["gate"]``. ``{"fail": m}`` raises ValueError(m),
    ``{"refuse": m}`` CommandError(m), ``{"lose": why}`` marks the actuator lost."""
    settings = ("gain", "fail")

    def open(self):
        self.ran: list = []

    def write(self, command):
        self.options["entered"].append(command)
        assert self.options["gate"].acquire(timeout=30.0)
        if isinstance(command, dict) and "fail" in command:
            raise ValueError(command["fail"])
        if isinstance(command, dict) and "refuse" in command:
            raise CommandError(self.name, command["refuse"])
        if isinstance(command, dict) and "lose" in command:
            self.mark_lost(command["lose"])
            return "marking lost"
        self.ran.append(command)
        return {"ran": command}

    def configure(self, key, value):
        if key == "fail":
            raise ValueError(value)
        return super().configure(key, value) if key != "gain" else value * 2


@pytest.fixture
def held():
    """A started host of one Held actuator: (host, port, entered, gate); stopped after."""
    made: list[ResourceHost] = []

    def make(port: HostPort | None = None):
        entered: list = []
        gate = threading.Semaphore(0)
        port = port or HostPort()
        host = host_of(Held, port=port, entered=entered, gate=gate)
        assert host.start() == {"arm": "actuator"}
        made.append(host)
        return host, port, entered, gate
    yield make
    for host in made:
        host.stop()


class Answers:
    """An on_done that keeps each answer as (ok, text)."""

    def __init__(self) -> None:
        self.got: list[tuple] = []

    def __call__(self, ok, value):
        self.got.append((ok, f"{type(value).__name__}: {value}" if isinstance(value, StdError)
                         else value))


# ---- the command path --------------------------------------------------------------------

def test_a_command_that_expired_in_the_queue_is_answered_so_counted_and_never_written(held):
    """The second command's sender gives up while the first is still being written: when
    its turn comes it is answered "expired in the queue", counted as expired (not as a
    command), never reaches write() and leaves no command record."""
    host, port, entered, gate = held()
    done = Answers()
    host.submit("arm", "write", ("first",), done, timeout=30.0)
    wait_for(lambda: entered == ["first"], what="the first command in write()")
    host.submit("arm", "write", ("late",), done, timeout=0.01)
    gave_up = time.monotonic() + 0.01
    wait_for(lambda: time.monotonic() > gave_up, what="the second sender's timeout")
    host.submit("arm", "write", ("third",), done, timeout=30.0)
    gate.release(2)
    wait_for(lambda: len(done.got) == 3, what="three answers")
    assert done.got == [(True, {"ran": "first"}), (False, "expired in the queue"),
                        (True, {"ran": "third"})]
    assert entered == ["first", "third"]
    counters = host.counters()["arm"]
    assert (counters["expired"], counters["commands"], counters["command_errors"]) == (1, 2, 0)
    wait_for(lambda: len(port.records) == 2, what="two records")   # published after the answer
    assert [r["v"]["command"] for _, r in port.records] == ["first", "third"]


def test_a_command_queued_while_its_actuator_was_lost_fails_with_the_reason(held):
    """The first command's write() marks the actuator lost; the command queued behind it
    is not written: its sender gets ResourceLost with the driver's reason (or just
    "lost" without one), and its record says so. Neither counts as a command error."""
    host, port, entered, gate = held()
    done = Answers()
    host.submit("arm", "write", ({"lose": "cable cut"},), done, timeout=30.0)
    wait_for(lambda: len(entered) == 1, what="the first command in write()")
    host.submit("arm", "write", ("second",), done, timeout=30.0)
    queued = time.time()
    wait_for(lambda: time.time() > queued + 0.001, what="the clock past the time it was queued")
    gate.release(1)
    wait_for(lambda: len(done.got) == 2, what="two answers")
    assert done.got == [(True, "marking lost"), (False, "ResourceLost: arm: lost: cable cut")]
    assert entered == [{"lose": "cable cut"}]
    assert port.states == [("arm", "lost", "cable cut")]
    wait_for(lambda: len(port.records) == 2, what="two records")
    assert [r for _, r in port.records] == [
        {"seq": 1, "t": port.records[0][1]["t"], "v": {"command": {"lose": "cable cut"},
                                                      "ok": "marking lost"}},
        {"seq": 2, "t": port.records[1][1]["t"], "v": {"command": "second",
                                                      "error": "lost: cable cut"}}]
    assert port.records[1][1]["t"] <= queued and {res for res, _ in port.records} == {"arm"}
    host.slots["arm"].obj.mark_ready()                   # the driver's link is back
    host.submit("arm", "write", ({"lose": ""},), done, timeout=30.0)
    wait_for(lambda: len(entered) == 2, what="the third command in write()")
    host.submit("arm", "write", ("fourth",), done, timeout=30.0)
    gate.release(1)
    wait_for(lambda: len(done.got) == 4, what="four answers")
    assert done.got[2:] == [(True, "marking lost"), (False, "ResourceLost: arm: lost")]
    counters = host.counters()["arm"]
    assert (counters["commands"], counters["command_errors"], counters["state"]) == (2, 0, "lost")


def test_an_actuators_errors_reach_the_sender_in_its_words_and_are_counted(held):
    """write() raising CommandError: the sender gets the actuator's reason as is; any
    other exception: its type and text. Each is a command error and its record says why
    and when it reached the host (it waited in the queue). configure() goes the same way
    but leaves no command record."""
    host, port, entered, gate = held()
    done = Answers()
    host.submit("arm", "write", ("hold",), done, timeout=30.0)
    wait_for(lambda: entered == ["hold"], what="the first command in write()")
    for command in ({"refuse": "too far"}, {"fail": "jam"}):
        host.submit("arm", "write", (command,), done, timeout=30.0)
    queued = time.time()
    wait_for(lambda: time.time() > queued + 0.001, what="the clock past the time they were queued")
    gate.release(3)
    wait_for(lambda: len(port.records) == 3, what="three records")    # published after the answer
    assert done.got == [(True, {"ran": "hold"}), (False, "too far"), (False, "ValueError: jam")]
    assert [(res, r["seq"], r["v"]) for res, r in port.records] == [
        ("arm", 1, {"command": "hold", "ok": {"ran": "hold"}}),
        ("arm", 2, {"command": {"refuse": "too far"}, "error": "too far"}),
        ("arm", 3, {"command": {"fail": "jam"}, "error": "ValueError: jam"})]
    assert all(r["t"] <= queued for _, r in port.records)
    gate.release(3)
    with pytest.raises(CommandError) as err:
        host.command("b", "arm", {"refuse": "too far"}, 5.0)
    assert str(err.value) == "arm: too far"
    with pytest.raises(CommandError) as err:
        host.command("b", "arm", {"fail": "jam"}, 5.0)
    assert str(err.value) == "arm: ValueError: jam"
    assert host.configure("arm", "gain", 4) == 8
    for key, message in [("speed", "arm: no setting 'speed' (settings: gain, fail)"),
                         ("fail", "arm: ValueError: 7")]:
        with pytest.raises(CommandError) as err:
            host.configure("arm", key, 7)
        assert str(err.value) == message
    assert host.command("b", "arm", "last", 5.0) == {"ran": "last"}
    wait_for(lambda: len(port.records) == 6, what="six records")
    assert [r["v"]["command"] for _, r in port.records][3:] == [      # none of configure()
        {"refuse": "too far"}, {"fail": "jam"}, "last"]
    counters = host.counters()["arm"]
    assert (counters["commands"], counters["command_errors"]) == (6, 6)


def test_a_command_records_time_is_when_it_reached_the_host_not_when_it_ran(held):
    """The record of a command that waited in the queue carries the time it was queued:
    before a moment taken while it still waited, not the time write() ran it."""
    host, port, entered, gate = held()
    done = Answers()
    before = time.time()
    host.submit("arm", "write", ("first",), done, timeout=30.0)
    host.submit("arm", "write", ("queued",), done, timeout=30.0)
    queued = time.time()
    wait_for(lambda: time.time() > queued + 0.001, what="the hclock past the time it was queued")
    waiting = time.time()
    gate.release(2)
    wait_for(lambda: len(port.records) == 2, what="two records")
    after = time.time()
    t2 = port.records[1][1]["t"]
    assert before - 1.0 < t2 <= queued < waiting < after


def test_records_share_a_message_until_their_batch_is_due_or_full(held, monkeypatch):
    """transport/records.py: an entry's records leave together, BATCH_S after the first
    (here long: none leaves before the host stops, then all in one message), or at once
    when BATCH_MAX of them wait (here 3: 5 commands make a message of 3, then one of 2)."""
    from esair_std.transport import records
    monkeypatch.setattr(records, "BATCH_S", 60.0)
    monkeypatch.setattr(records, "BATCH_MAX", 3)
    host, port, entered, gate = held()
    gate.release(5)
    for i in range(5):
        assert host.command("b", "arm", i, 5.0) == {"ran": i}
    assert port.batches == [("arm", 3)]           # the full one went at once
    host.stop()
    assert port.batches == [("arm", 3), ("arm", 2)]   # the rest when the host stopped
    assert [(r, rec["seq"], rec["v"]) for r, rec in port.records] == [
        ("arm", i + 1, {"command": i, "ok": {"ran": i}, "by": "b"}) for i in range(5)]


def test_a_record_leaves_by_itself_once_its_batch_is_due(held, monkeypatch):
    """No other command comes: the host's thread publishes the lone record when its
    BATCH_S is up (it waits for it as for its next command), not at the next command."""
    from esair_std.transport import records
    monkeypatch.setattr(records, "BATCH_S", 0.2)
    host, port, entered, gate = held()
    gate.release(1)
    assert host.command("b", "arm", "alone", 5.0) == {"ran": "alone"}
    wait_for(lambda: port.batches == [("arm", 1)], what="the lone record's batch")
    assert host.thread.is_alive()


def test_a_listener_keeps_only_the_records_of_the_entry_whose_key_it_heard():
    """A batch on commands/papaman speaks for papaman and papaman.<child> only: an item
    naming another entry's actuator, or no record at all, is left out and counted."""
    from esair_std.transport import keys, records
    key = keys.commands("lab", "papaman")
    ok = {"r": "papaman.servo.l_knee", "seq": 4, "t": 1.5, "v": {"command": 90, "ok": "odd090"}}
    got, bad = records.unpack(key, [
        ok, {"r": "papaman", "seq": 1, "t": 2.0, "v": {"command": "x", "error": "no"}},
        {"r": "arm", "seq": 1, "t": 1.0, "v": {"command": 1, "ok": 1}},       # another entry
        {"r": "papamanx.servo", "seq": 1, "t": 1.0, "v": {}},          # not a child of it
        {"r": "papaman.servo.l_hip", "seq": 1, "t": 1.0, "v": "not a dict"}, "garbage", None])
    assert got == [("papaman.servo.l_knee", {"seq": 4, "t": 1.5, "v": ok["v"]}),
                   ("papaman", {"seq": 1, "t": 2.0, "v": {"command": "x", "error": "no"}})]
    assert bad == 5
    assert records.unpack(key, {"r": "papaman"}) == ([], 1)        # not a list
    assert keys.commands_all("lab") == "esair/lab/commands/*"
    assert key == "esair/lab/commands/papaman"


def test_a_record_that_cannot_be_published_is_logged_and_the_sender_has_its_answer(
        held, caplog):
    host, port, entered, gate = held(HostPort(fail_records="no route"))
    gate.release(2)
    assert host.command("b", "arm", "fine", 5.0) == {"ran": "fine"}
    with pytest.raises(CommandError):
        host.command("b", "arm", {"fail": "jam"}, 5.0)
    wait_for(lambda: host.counters()["records_unsent"] == 2, what="two records counted unsent")
    # both in one batch, or each in its own when the second came past the first's BATCH_S
    assert logged(caplog, "esair_std.resource") in (
        [("WARNING", "arm: 2 command records not published: no route")],
        [("WARNING", "arm: 1 command record not published: no route")] * 2)


def test_submit_refuses_a_full_queue_and_counts_every_refusal(held):
    """Two commands past the bound of 256 while the actuator is busy: both refused with
    the reason, and both counted."""
    host, port, entered, gate = held()
    done = Answers()
    host.submit("arm", "write", ("busy",), done, timeout=30.0)
    wait_for(lambda: entered == ["busy"], what="the first command in write()")
    for i in range(reshost.COMMANDS):
        host.submit("arm", "write", (i,), done, timeout=30.0)
    host.submit("arm", "write", ("one too many",), done, timeout=30.0)
    host.submit("arm", "write", ("two too many",), done, timeout=30.0)
    assert done.got == [(False, "command queue full")] * 2
    assert host.counters()["commands_refused"] == 2
    gate.release(reshost.COMMANDS + 1)
    wait_for(lambda: len(done.got) == reshost.COMMANDS + 3, what="every command answered")


# ---- the life of a host ---------------------------------------------------------------------

class Plain(Actuator):
    """An actuator that keeps what it was given at construction (before open())."""

    def __init__(self):
        self.given = (self.name, dict(self.options))

    def write(self, command):
        return self.given


def test_a_host_that_never_started_stops_without_an_error():
    host = host_of(Plain, "wheel")
    host.stop()
    assert host.state == "stopped" and not host.thread.is_alive()


def test_a_host_starts_as_starting_then_is_ready_on_a_daemon_thread_named_after_it(caplog):
    """Before start() the entry is "starting"; after, "ready"; its thread is a daemon (a
    driver stuck in write() never keeps the runtime's process from exiting) named after
    the entry. Its resource read its name and options in __init__. A host without a
    driver closes its resources and logs nothing."""
    host = host_of(Plain, "wheel", speed=3)
    assert (host.state, host.reason, host.driver, host.on_failed) == ("starting", "", None, None)
    assert host.thread.daemon and host.thread.name == "esair:wheel"
    assert host.start(5.0) == {"wheel": "actuator"}
    assert host.state == "ready"
    assert host.command("b", "wheel", 1, 5.0) == ["wheel", {"speed": 3}]
    host.stop()
    assert host.state == "stopped" and logged(caplog, "esair_std.resource") == []


class Dies(Actuator):
    def write(self, command):
        raise SystemExit(command)


def test_a_host_that_dies_with_nobody_to_tell_ends_quietly(caplog):
    """No on_failed set (nobody supervises it): the host's death is logged, its resource
    lost, and its thread ends without an error of its own."""
    seen: list = []
    old, threading.excepthook = threading.excepthook, seen.append
    try:
        host = host_of(Dies, "arm")
        host.start(5.0)
        with pytest.raises(ResourceLost) as err:
            host.command("b", "arm", "power cut", 5.0)
        assert str(err.value) == "arm: its host died: SystemExit: power cut"
        host.thread.join(5.0)
    finally:
        threading.excepthook = old
    assert seen == [] and not host.thread.is_alive()
    assert (host.state, host.states()) == ("failed", {
        "arm": ("lost", "its host died: SystemExit: power cut")})
    assert logged(caplog, "esair_std.resource") == [("ERROR", "arm: its host died: SystemExit: power cut")]


class NoDict(Driver):
    def resources(self):
        return self.options["kids"]


class NotOne:
    pass


class Named(Sensor):
    pass


@pytest.mark.parametrize("cls, options, message", [
    (NoDict, {"kids": {}}, "ComponentError: resources() gave no {child: Sensor|Actuator} dict"),
    (NoDict, {"kids": ["a", "b"]},
     "ComponentError: resources() gave no {child: Sensor|Actuator} dict"),
    (NoDict, {"kids": {"a": Named(), "b": NotOne()}}, "ComponentError: bad.b: not a Sensor or Actuator"),
    (NotOne, {}, f"ComponentError: {__name__}:NotOne is not a Sensor, Actuator or Driver"),
])
def test_a_resource_that_is_no_resource_fails_to_open_with_the_reason(cls, options, message):
    host = host_of(cls, "bad", **options)
    with pytest.raises(ComponentError) as err:
        host.start(5.0)
    assert str(err.value) == f"resource 'bad' failed to open: {message}"
    host.thread.join(5.0)
    assert not host.thread.is_alive()


class Slow(Sensor):
    def open(self):
        self.options["opening"].set()
        self.options["go"].wait(10.0)


def test_a_device_that_does_not_open_in_time_fails_with_the_reason():
    opening, go = threading.Event(), threading.Event()
    host = host_of(Slow, "cam", opening=opening, go=go)
    try:
        with pytest.raises(ComponentError) as err:
            host.start(0.05)
        assert str(err.value) == "resource 'cam' did not open within 0.05 s"
        assert opening.is_set()
    finally:
        go.set()
    host.thread.join(5.0)
    assert not host.thread.is_alive()          # told to stop while it opened: it ended


# ---- the sensor poll ----------------------------------------------------------------------

class HostClock:
    """time.monotonic / time.time for the resource host: moved by the test."""

    def __init__(self) -> None:
        self.now = 1000.0

    def monotonic(self) -> float:
        return self.now

    def time(self) -> float:
        return self.now


class Scripted(Sensor):
    """read() gives the next of ``options["values"]``; "raise" raises, "slow" moves the
    test's hclock by ``options["slow"]`` s (a read that took that long)."""

    def read(self):
        v = self.options["values"].pop(0)
        if v == "raise":
            raise OSError("unplugged")
        if v == "slow":
            self.options["hclock"].now += self.options["slow"]
            return "slow"
        return v


class Pushes(Sensor):
    """No rate: reports itself; read() must never be called."""

    def read(self):
        raise AssertionError("polled without a rate")


class Beat(Sensor):
    def read(self):
        return "beat"


class Servo(Actuator):
    """An actuator with a rate of its own: never polled (an actuator is not read)."""

    rate_hz = 8.0


class Sensors(Driver):
    def resources(self):
        return {"a": Scripted(), "b": Pushes(), "c": Beat(), "d": Servo()}


@pytest.fixture
def hclock(monkeypatch):
    c = HostClock()
    monkeypatch.setattr(reshost, "time", c)
    return c


def opened(cls, hclock, name="s", **options) -> tuple[ResourceHost, HostPort]:
    """A host whose device is open but whose thread does not run: the test polls."""
    port = HostPort()
    host = host_of(cls, name, port=port, hclock=hclock, **options)
    host._open()
    for s in host.slots.values():
        s.next_poll = hclock.now                 # as the host thread does once opened
    return host, port


def test_a_sensor_is_read_when_due_and_the_host_sleeps_until_the_next_one_is(hclock, monkeypatch):
    """rate_hz 8 (the deployment's option wins over the class's 2): read at once, then
    every 0.125 s; None reports nothing; between reads the host may sleep until the next
    is due, never longer than 0.5 s."""
    monkeypatch.setattr(Scripted, "rate_hz", 2.0, raising=False)
    host, port = opened(Scripted, hclock, rate_hz=8, values=[1, None, 3])
    assert host.slots["s"].obj.rate_hz == 8.0
    assert host._poll() == 0.125 and port.samples == [("s", 1, 1, "s")]
    hclock.now += 0.0625
    assert host._poll() == 0.0625 and len(port.samples) == 1
    hclock.now += 0.0625
    assert host._poll() == 0.125 and len(port.samples) == 1      # None: nothing reported
    hclock.now += 0.125
    assert host._poll() == 0.125 and port.samples[-1] == ("s", 2, 3, "s")
    counters = host.counters()["s"]
    assert (counters["reported"], counters["seq"], counters["polls_late"]) == (2, 2, 0)


@pytest.mark.parametrize("rate, hz, wait", [(0, 8.0, 0.125), (-5, 8.0, 0.125), ("10", 8.0, 0.125),
                                            (None, 8.0, 0.125), (1, 1.0, 0.5), (16.0, 16.0, 0.0625)])
def test_the_deployments_rate_wins_only_when_it_is_a_positive_number(hclock, monkeypatch,
                                                                      rate, hz, wait):
    """The class reads at 8 Hz; a deployment's rate_hz of 0, a negative one, a string or
    none leaves it so, a positive number (1 too) replaces it."""
    monkeypatch.setattr(Scripted, "rate_hz", 8.0, raising=False)
    host, port = opened(Scripted, hclock, rate_hz=rate, values=[1])
    assert host.slots["s"].obj.rate_hz == hz
    assert host._poll() == wait and port.samples == [("s", 1, 1, "s")]


@pytest.mark.parametrize("took, late, wait", [(0.25, 1, 0.125), (0.125, 0, 0.0)])
def test_a_slow_read_is_counted_late_and_the_next_is_a_full_period_after_it(hclock, took, late, wait):
    """A read that takes 0.25 s at 8 Hz: counted once in polls_late, and the next read
    is due 0.125 s after it ended (no burst of reads to catch up). One that takes just
    its period is not late: the next is due at once, on its schedule."""
    host, port = opened(Scripted, hclock, rate_hz=8, values=["slow", 2, 3], slow=took)
    assert host._poll() == wait and host.counters()["s"]["polls_late"] == late
    if wait:
        hclock.now += 0.0625
        assert host._poll() == 0.0625 and len(port.samples) == 1
        hclock.now += 0.0625
    host._poll()
    assert [s[2] for s in port.samples] == ["slow", 2]
    assert host.counters()["s"]["polls_late"] == late


def test_a_read_that_raises_loses_the_sensor_with_the_reason_and_it_is_not_polled_again(hclock):
    """a's second read raises: a is lost with "read() raised OSError: unplugged",
    reported once, never read again, while c beside it in the same driver goes on; b
    (no rate) and d (an actuator) are never polled."""
    host, port = opened(Sensors, hclock, "dev", values=[1, "raise", 3])
    host.slots["dev.a"].obj.rate_hz = host.slots["dev.c"].obj.rate_hz = 4.0
    assert host._poll() == 0.25
    hclock.now += 0.25
    assert host._poll() == 0.25
    assert port.states == [("dev.a", "lost", "read() raised OSError: unplugged")]
    hclock.now += 1.0
    assert host._poll() == 0.25
    assert port.samples == [("dev.a", 1, 1, "dev.a"), ("dev.c", 1, "beat", "dev.c"),
                            ("dev.c", 2, "beat", "dev.c"), ("dev.c", 3, "beat", "dev.c")]
    assert len(port.states) == 1 and host.slots["dev.a"].obj.options["values"] == [3]
    assert host.counters()["dev.c"]["polls_late"] == 1
    assert host.states() == {"dev.a": ("lost", "read() raised OSError: unplugged"),
                             "dev.b": ("ready", ""), "dev.c": ("ready", ""), "dev.d": ("ready", "")}


def test_the_nearest_due_sensor_sets_how_long_the_host_sleeps(hclock):
    """Two sensors at 2 and 8 Hz, in either order: the host sleeps until the faster is due."""
    for first, second in [(2.0, 8.0), (8.0, 2.0)]:
        host, port = opened(Sensors, hclock, "dev", values=[1, 2, 3])
        host.slots["dev.a"].obj.rate_hz = first
        host.slots["dev.c"].obj.rate_hz = second
        assert host._poll() == 0.125
        hclock.now += 0.125
        assert host._poll() == 0.125
        assert len(port.samples) == 3 and port.states == []


def test_a_commands_deadline_is_exact_it_runs_at_its_deadline_and_is_dropped_past_it(hclock, held):
    """With the host's clock held by the test: a command whose deadline is reached just
    as its turn comes is still written; one whose deadline has passed is answered
    "expired in the queue" and never written."""
    host, port, entered, gate = held()
    done = Answers()
    host.submit("arm", "write", ("hold",), done, timeout=30.0)
    wait_for(lambda: entered == ["hold"], what="the first command in write()")
    host.submit("arm", "write", ("at its deadline",), done, timeout=0.5)
    hclock.now += 0.5
    gate.release(2)
    wait_for(lambda: len(done.got) == 2, what="two answers")
    host.submit("arm", "write", ("hold 2",), done, timeout=30.0)
    wait_for(lambda: len(entered) == 3, what="the third command in write()")
    host.submit("arm", "write", ("past it",), done, timeout=0.5)
    hclock.now += 0.5625
    gate.release(1)
    wait_for(lambda: len(done.got) == 4, what="four answers")
    assert done.got == [(True, {"ran": "hold"}), (True, {"ran": "at its deadline"}),
                        (True, {"ran": "hold 2"}), (False, "expired in the queue")]
    assert entered == ["hold", "at its deadline", "hold 2"]
