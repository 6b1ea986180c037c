"""The supervisor's rules (esair_std/supervisor.py), each with a test that fails when the
rule breaks: driven through its own API with hosts that say what happened to them, under
a clock the test moves."""

from __future__ import annotations

import threading

import pytest

from esair_std import supervisor
from esair_std.errors import ControlError
from esair_std.supervisor import ChildSpec, Record, Starting, Supervisor
from tests.support.std import in_thread, logged, wait_for


class Host:
    """A started child: its state; its stop() is recorded in the supervisor's events."""

    def __init__(self, events: list, name: str, generation: int, state: str = "ready",
                 reason: str = ""):
        self.events, self.name, self.generation = events, name, generation
        self.state, self.reason = state, reason
        self.timeouts: list = []
        self.on_stop = lambda: None

    def stop(self, timeout: float = 2.0) -> None:
        self.events.append(("stop", self.name, self.generation))
        self.timeouts.append(timeout)
        self.on_stop()


class Spec:
    def __init__(self, name: str, restart_max: int = 0, restart_within: float = 10.0):
        self.name, self.kind = name, "behavior"
        self.restart_max, self.restart_within = restart_max, restart_within


class Clock:
    """time.monotonic for the supervisor: moved by the test."""

    def __init__(self) -> None:
        self.now = 1000.0

    def monotonic(self) -> float:
        return self.now


class Recording(Supervisor):
    """A supervisor that records what it says to its subclass, in order."""

    def __init__(self, fail_start: set[int] | None = None, failed_start: set[int] | None = None,
                 no_reason: bool = False):
        self.events: list[tuple] = []
        self.hosts: list[Host] = []
        self.while_starting: list[str] = []     # the child's host state seen by its start
        self.fail_start = fail_start or set()
        self.failed_start = failed_start or set()
        self.no_reason = no_reason
        super().__init__("test", self._start)

    def _start(self, spec, generation):
        self.events.append(("start", spec.name, generation))
        self.while_starting.append(getattr(self.records[spec.name].host, "state", None))
        if generation in self.fail_start:
            raise RuntimeError(f"cannot start generation {generation}")
        state = "failed" if generation in self.failed_start else "ready"
        host = Host(self.events, spec.name, generation, state,
                    "open failed" if state == "failed" else "")
        if self.no_reason:
            del host.reason                     # a host that gives no reason
        self.hosts.append(host)
        return host

    def released(self, name, rec, why):
        assert name == rec.spec.name            # the name it was told is the record's
        self.events.append(("released", name, why))

    def restarted(self, name, rec):
        self.events.append(("restarted", name, rec.generation))

    def gave_up(self, name, rec):
        self.events.append(("gave_up", name, rec.reason))

    def barrier(self) -> None:
        """Every request and failure queued before this one is handled."""
        self.request(lambda: None)

    def take(self) -> list[tuple]:
        out, self.events[:] = list(self.events), []
        return out


@pytest.fixture
def clock(monkeypatch):
    c = Clock()
    monkeypatch.setattr(supervisor, "time", c)
    return c


@pytest.fixture
def sup():
    made: list[Recording] = []

    def make(**kw) -> Recording:
        s = Recording(**kw)
        s.start()
        made.append(s)
        return s
    yield make
    for s in made:
        s.stop_children()


def test_a_child_spec_takes_its_restart_policy_from_the_component():
    child = ChildSpec.of(Spec("walker", restart_max=3, restart_within=2.5))
    assert child == ChildSpec("walker", "behavior", 3, 2.5, "stay")
    unset = Spec("w", restart_max=None, restart_within=None)
    assert ChildSpec.of(unset) == ChildSpec("w", "behavior", 0, 0.0)
    with pytest.raises(ValueError) as err:
        ChildSpec("w", "behavior", past_limit="retry")
    assert str(err.value) == "past_limit must be one of ('stay', 'remove'), not 'retry'"
    assert Record(Spec("x", 2, 1.0), Starting()).child == ChildSpec("x", "behavior", 2, 1.0)


# ---- the supervisor ---------------------------------------------------------------------

def test_failures_restart_a_child_up_to_its_limit_then_it_stays_failed(sup, clock, caplog):
    s = sup()
    changes: list[int] = []
    s.on_change = lambda: changes.append(1)
    rec = s.request(s.add_child, Spec("w", restart_max=2, restart_within=10.0))
    assert s.take() == [("start", "w", 1)] and len(changes) == 1
    s.failed("w", 1, "boom")
    s.barrier()
    assert s.take() == [("released", "w", "failed"), ("stop", "w", 1), ("start", "w", 2),
                        ("restarted", "w", 2)]
    assert (rec.generation, rec.restarts, rec.reason, s.c["restarts"]) == (2, 1, "boom", 1)
    assert len(changes) == 2
    s.failed("w", 1, "late news of generation 1")      # already handled: no event
    s.failed("w", 2, "boom 2")
    s.failed("w", 2, "boom 2 again")                    # one generation fails once
    s.barrier()
    assert s.take() == [("released", "w", "failed"), ("stop", "w", 2), ("start", "w", 3),
                        ("restarted", "w", 3)]
    clock.now += 10.0                                   # both failures within 10 s: the limit
    s.failed("w", 3, "boom 3")
    s.barrier()
    assert s.take() == [("released", "w", "failed"), ("stop", "w", 3), ("gave_up", "w", "boom 3")]
    assert s.records["w"] is rec and (rec.generation, rec.restarts, s.c["restarts"]) == (3, 2, 2)
    assert [h.timeouts for h in s.hosts] == [[0.2], [0.2], [0.2]]   # a dead host: a short wait
    assert s.while_starting == ["starting"] * 3          # never a host that is gone
    assert logged(caplog, "esair_std.supervisor") == [
        ("WARNING", "w failed (boom); restart 1"), ("WARNING", "w failed (boom 2); restart 2"),
        ("WARNING", "w failed (boom 3); stays failed")]


def test_a_failure_older_than_the_period_no_longer_counts(sup, clock):
    s = sup()
    s.request(s.add_child, Spec("w", restart_max=1, restart_within=5.0))
    s.failed("w", 1, "boom")
    s.barrier()
    clock.now += 5.001
    s.failed("w", 2, "boom")
    s.barrier()
    assert s.take()[-2:] == [("start", "w", 3), ("restarted", "w", 3)]
    clock.now += 5.0
    s.failed("w", 3, "boom")
    s.barrier()
    assert s.take()[-1] == ("gave_up", "w", "boom")


def test_a_child_past_its_limit_is_dropped_when_its_policy_says_remove(sup, clock):
    s = sup()
    rec = s.request(s.add_child, Spec("w"))
    rec.child = ChildSpec("w", "behavior", 0, 10.0, "remove")
    s.failed("w", 1, "boom")
    s.barrier()
    assert s.take()[-1] == ("gave_up", "w", "boom") and "w" not in s.records


def test_a_restart_that_fails_leaves_the_child_failed(sup, clock, caplog):
    s = sup(fail_start={2})
    rec = s.request(s.add_child, Spec("w", restart_max=3))
    s.failed("w", 1, "boom")
    s.barrier()
    assert s.take()[-2:] == [("start", "w", 2),
                             ("gave_up", "w", "restart failed: cannot start generation 2")]
    assert (rec.host.state, rec.host.reason) == ("failed", "restart failed: cannot start generation 2")
    s.failed("w", 2, "boom")                            # a failed restart is not started again
    s.barrier()
    assert s.take() == []
    assert logged(caplog, "esair_std.supervisor")[-1] == (
        "ERROR", "w: restart failed: cannot start generation 2")


def test_a_restarted_child_that_comes_up_failed_is_a_failure_of_its_own(sup, clock):
    s = sup(failed_start={2})
    s.request(s.add_child, Spec("w", restart_max=1))
    s.take()
    s.failed("w", 1, "boom")
    s.barrier()
    assert s.take() == [("released", "w", "failed"), ("stop", "w", 1), ("start", "w", 2),
                        ("released", "w", "failed"), ("stop", "w", 2),
                        ("gave_up", "w", "open failed")]


def test_a_host_that_comes_up_failed_without_a_reason_fails_with_an_empty_one(sup):
    s = sup(failed_start={1, 2}, no_reason=True)
    rec = s.request(s.add_child, Spec("w", restart_max=1))
    assert s.take() == [("start", "w", 1), ("released", "w", "failed"), ("stop", "w", 1),
                        ("start", "w", 2), ("released", "w", "failed"), ("stop", "w", 2),
                        ("gave_up", "w", "")]
    assert rec.reason == ""
    once = sup(failed_start={1}, no_reason=True)     # no restart: generation 1's own reason
    once.request(once.add_child, Spec("x"))
    assert once.take()[-1] == ("gave_up", "x", "") and once.records["x"].reason == ""


def test_a_child_that_starts_failed_is_handled_at_once_and_one_that_cannot_start_is_not_kept(sup):
    s = sup(failed_start={1})
    s.request(s.add_child, Spec("w"))
    assert s.take() == [("start", "w", 1), ("released", "w", "failed"), ("stop", "w", 1),
                        ("gave_up", "w", "open failed")]
    s2 = sup(fail_start={1})
    with pytest.raises(RuntimeError, match="cannot start generation 1"):
        s2.request(s2.add_child, Spec("x"))
    assert s2.records == {}


@pytest.mark.parametrize("release_first, order", [
    (False, [("stop", "w", 1), ("released", "w", "removed")]),
    (True, [("released", "w", "removed"), ("stop", "w", 1)])])
def test_remove_stops_and_releases_in_the_kinds_order_and_its_failure_is_no_event(
        sup, release_first, order, caplog):
    s = sup()
    s.release_before_stop = release_first
    s.request(s.add_child, Spec("w", restart_max=5))
    s.take()
    seen: list = []
    s.released = lambda name, rec, why: (seen.append(("w" in s.records, rec.spec.name)),
                                         s.events.append(("released", name, why)))
    rec = s.request(s.remove_child, "w")
    assert s.take() == order and "w" not in s.records and rec.removing
    assert seen == [(False, "w")]          # forgotten before it is released, in both orders
    s.failed("w", 1, "it died after it was removed")
    s.barrier()
    assert s.take() == [] and logged(caplog, "esair_std.supervisor") == []


def test_a_late_failure_of_a_removed_childs_instance_never_fails_the_one_added_again(sup):
    """w runs as generation 2 (restarted once), is removed and added again (generation 1
    of a new record); the old generation 2's failure arriving late is no event."""
    s = sup()
    s.request(s.add_child, Spec("w", restart_max=5))
    s.failed("w", 1, "boom")
    s.barrier()
    s.request(s.remove_child, "w")
    rec = s.request(s.add_child, Spec("w", restart_max=5))
    s.take()
    s.failed("w", 2, "late news of the removed one")
    s.barrier()
    assert s.take() == [] and (rec.generation, rec.restarts, rec.reason) == (1, 0, "")


def test_a_failure_reported_while_the_child_is_being_removed_is_no_event(sup, caplog):
    """The host's stop() reports its child's failure on the supervisor's own thread (so it
    is handled at once, inside the remove): it must not restart what is being removed."""
    s = sup()
    rec = s.request(s.add_child, Spec("w", restart_max=5))
    rec.host.on_stop = lambda: s.request(s._failed, "w", 1, "it died while stopping")
    s.take()
    s.request(s.remove_child, "w")
    assert s.take() == [("stop", "w", 1), ("released", "w", "removed")]
    assert "w" not in s.records and logged(caplog, "esair_std.supervisor") == []


def test_a_failure_that_cannot_be_queued_is_logged_not_waited_for(sup, caplog):
    """The supervisor's queue is full (its thread is busy): a host reporting a failure
    waits a bounded time, then the failure is logged, and the host goes on; a request is
    refused with a reason."""
    s = sup()
    busy, release = threading.Event(), threading.Event()
    s.failed("w", 1, "x")           # nobody named w: handled as no event
    t, _ = in_thread(s.request, lambda: (busy.set(), release.wait(30.0)))
    busy.wait(10.0)
    for i in range(supervisor.REQUESTS):
        s.failed(f"c{i}", 1, "fills the queue")
    s.failed("w", 1, "one too many")               # returns: not blocked forever
    with pytest.raises(ControlError) as err:        # and a request is refused, not blocked
        s.request(lambda: "never run")
    assert err.value.message == "the supervisor is busy: try again"
    release.set()
    t.join(10.0)
    assert logged(caplog, "esair_std.supervisor") == [
        ("ERROR", "failure of w not queued: supervisor queue full")]


def test_a_failure_event_that_raises_is_logged_and_the_supervisor_goes_on(sup, caplog):
    """Handling a failure raised (here the subclass's gave_up()): nobody waits for that
    event, so it is logged with its reason, and the supervisor serves what comes next."""
    s = sup()
    s.request(s.add_child, Spec("w"))

    def gave_up(name, rec):
        raise RuntimeError("nobody listens")
    s.gave_up = gave_up
    s.failed("w", 1, "boom")
    assert s.request(lambda: "still serving") == "still serving"
    assert logged(caplog, "esair_std.supervisor") == [
        ("WARNING", "w failed (boom); stays failed"), ("ERROR", "supervisor: nobody listens")]


def test_stopping_stops_every_child_newest_first_and_then_takes_no_request(sup):
    s = sup()
    for name in ("a", "b", "c"):
        s.request(s.add_child, Spec(name, restart_max=5))
    s.take()
    s.stop_children()
    assert s.take() == [("stop", "c", 1), ("released", "c", "removed"), ("stop", "b", 1),
                        ("released", "b", "removed"), ("stop", "a", 1), ("released", "a", "removed")]
    assert s.records == {}
    with pytest.raises(ControlError) as err:
        s.request(lambda: 1)
    assert err.value.message == "the runtime is stopping"
    s.failed("a", 1, "after the end")
    assert s.take() == []


def test_a_request_gives_its_result_or_its_exception_and_gives_up_at_its_timeout(sup):
    s = sup()
    assert s.request(lambda a, b: a + b, 2, 3) == 5
    with pytest.raises(KeyError):
        s.request(s.remove_child, "nobody")
    assert s.request(lambda: s.request(lambda: "inline")) == "inline"   # on its own thread
    me = threading.current_thread()
    assert s.request(lambda: (threading.current_thread() is not me, threading.current_thread().name,
                              threading.current_thread().daemon)) == (True, "esair:test", True)
    release = threading.Event()
    with pytest.raises(ControlError) as err:
        s.request(release.wait, timeout=0.1)
    assert err.value.message == "request not done within 0.1 s"
    release.set()
    assert s.request(lambda: "free again") == "free again"


def test_stopping_waits_for_the_work_under_way_and_never_raises_on_a_full_queue(sup):
    s = sup()
    s.request(s.add_child, Spec("w"))
    s.take()
    busy, release = threading.Event(), threading.Event()

    workers: list = []

    def restart_under_way():
        workers.append(threading.current_thread())
        busy.set()
        release.wait(30.0)
        s.events.append(("work done",))
    t, _ = in_thread(s.request, restart_under_way)
    busy.wait(10.0)
    for i in range(supervisor.REQUESTS):
        s.failed(f"c{i}", 1, "fills the queue")
    stopper, box = in_thread(s.stop_children)
    wait_for(lambda: s._closing, what="stop_children under way")
    release.set()
    stopper.join(10.0)
    t.join(10.0)
    assert box == [None]                            # returned, did not raise
    workers[0].join(10.0)
    assert not workers[0].is_alive()                # the events queued after the stop are dropped
    assert s.take() == [("work done",), ("stop", "w", 1), ("released", "w", "removed")]


def test_before_start_a_request_runs_in_the_callers_thread():
    s = Recording()
    assert s.request(threading.current_thread) is threading.current_thread()
    s.add_child(Spec("w"))
    assert s.take() == [("start", "w", 1)]
    s.stop_children()
    assert s.take() == [("stop", "w", 1), ("released", "w", "removed")]


def test_a_starting_host_takes_nothing():
    h = Starting()
    assert (h.state, h.phase, h.reason) == ("starting", "starting", "")
    assert h.offer("a", 1) == "starting" and h.provide("a", 1.0) == ("busy", "starting")
    assert h.check(0.0) is None and h.children() == {} and h.counters() == {}
    failed = Starting("failed", "restart failed: x")
    assert (failed.state, failed.reason, failed.offer("a", 1)) == ("failed", "restart failed: x", "failed")
