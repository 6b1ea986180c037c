"""The connections' rules (esair_std/connections.py: the SC's and AC's handles), each
with a test that fails when the rule breaks, driven through their handles."""

from __future__ import annotations

import threading

import pytest

from esair_std.connections import ActuatorConnection, ActuatorHandle, SensorConnection, SensorHandle
from esair_std.errors import CommandError, Refused, ResourceLost, StdError
from esair_std.level import Level
from esair_std.sample import Sample


# ---- the connections --------------------------------------------------------------------

def sample(seq: int) -> Sample:
    return Sample(seq, seq, 0.0, "count")


def test_a_sensor_handle_keeps_the_newest_and_counts_what_a_reader_lost():
    states = {"count": "ready"}
    h = SensorHandle("count", 2, states.get)
    assert h.latest() is None and h.state == "ready"
    for i in (1, 2, 3):
        h.push(sample(i))
    # samples() never called: the reader only looks at latest(), nothing is "lost"
    assert h.counters() == {"received": 3, "overwritten": 0, "missed": 0} and h.latest().seq == 3
    assert [s.seq for s in h.samples()] == [2, 3] and h.samples() == []
    for i in (4, 5, 6, 7, 8):           # into 2 places: 6, 7 and 8 each push one out
        h.push(sample(i))
    assert h.counters() == {"received": 8, "overwritten": 3, "missed": 0}
    assert [s.seq for s in h.samples()] == [7, 8]
    h.detached = True
    h.push(sample(9))
    assert h.counters() == {"received": 8, "overwritten": 3, "missed": 0} and h.latest().seq == 8
    assert h.state == "detached"
    del states["count"]
    h.detached = False
    assert h.state == "gone"
    one = SensorHandle("count", 0, states.get)         # keep 0 still keeps one
    one.push(sample(1))
    one.push(sample(2))
    assert [s.seq for s in one.samples()] == [2]


def test_a_sensor_handle_counts_the_samples_that_never_reached_it():
    h = SensorHandle("count", 64, {"count": "ready"}.get)
    for i in (5, 6, 9, 10, 14):        # from 5: those before it reached no handle yet
        h.push(sample(i))
    assert h.counters() == {"received": 5, "overwritten": 0, "missed": 2 + 3}
    for i in (1, 2, 4):                # the sensor restarted: it numbers from 1 again
        h.push(sample(i))
    assert h.counters() == {"received": 8, "overwritten": 0, "missed": 5 + 1}
    assert [s.seq for s in h.samples()] == [5, 6, 9, 10, 14, 1, 2, 4]


def test_an_actuator_handle_raises_only_the_documented_errors_and_counts_them():
    calls: list = []

    def send(resource, command, timeout):
        calls.append((resource, command, timeout))
        if command == "refuse":
            raise Refused("not today")
        if command == "not json":
            raise StdError("a set is not JSON")
        if command == "bad":
            raise CommandError(resource, "too far")
        if command == "gone":
            raise ResourceLost(resource, "lost: cable out")
        return {"n": len(calls)}

    h = ActuatorHandle("arm", send, {"arm": "ready"}.get)
    assert h.send(1, 0.25) == {"n": 1} and calls == [("arm", 1, 0.25)]
    assert h.send(2) == {"n": 2} and calls[-1][2] == 1.0
    for command, kind, message in [("refuse", CommandError, "arm: refused: not today"),
                                   ("not json", CommandError, "arm: a set is not JSON"),
                                   ("bad", CommandError, "arm: too far"),
                                   ("gone", ResourceLost, "arm: lost: cable out")]:
        with pytest.raises(StdError) as err:
            h.send(command)
        assert type(err.value) is kind and str(err.value) == message
    assert h.counters() == {"sent": 2, "failed": 4}
    h.detached = True
    with pytest.raises(ResourceLost) as err:
        h.send(3)
    assert str(err.value) == "arm: detached: the resource was removed" and len(calls) == 6
    assert h.counters() == {"sent": 2, "failed": 5} and h.state == "detached"


def test_the_sensor_connection_routes_detaches_parks_and_restores():
    sc = SensorConnection()
    a1, a2, b = (SensorHandle("count", 4, lambda r: "ready") for _ in range(3))
    sc.attach("a", "count", a1)
    sc.attach("a", "count", a2)
    sc.attach("b", "count", b)
    sc.attach("b", "other", None)                      # process mode: listed only
    sc.route("count", sample(1))
    sc.route("nobody", sample(2))
    assert (sc.routed, sc.unrouted) == (1, 1)
    assert [h.received for h in (a1, a2, b)] == [1, 1, 1]
    assert sc.attached_to("count") == ["a", "b"] and sc.attached_to("other") == ["b"]
    assert sc.detach("b", "other") == ["other"] and sc.attached_to("other") == []
    assert sc.detach("b", "count") == ["count"] and b.detached and not a1.detached
    assert sc.drop_resource("count") == ["a"] and a1.detached and a2.detached
    sc.route("count", sample(3))
    assert sc.unrouted == 2 and sc.attached_to("count") == []
    sc.restore("a", "count")
    assert not a1.detached and not a2.detached and sc.attached_to("count") == ["a"]
    sc.route("count", sample(4))
    assert [h.received for h in (a1, a2, b)] == [2, 2, 1] and a1.latest().seq == 4
    sc.restore("c", "count")                           # nothing parked: listed
    assert sc.attached_to("count") == ["a", "c"]
    sc.route("count", sample(5))                       # its None handle is skipped
    assert sc.routed == 3
    # parked, then forgotten: not restored when the sensor comes back
    sc.drop_resource("count")
    sc.forget("a")
    sc.restore("a", "count")
    assert a1.detached and sc.attached_to("count") == ["a"]
    assert sc.detach("a") == ["count"] and sc.attached_to("count") == []
    assert sc.drop_resource("never") == []


def test_each_behavior_gets_its_own_handles_back_when_a_sensor_returns():
    sc = SensorConnection()
    a, b = SensorHandle("count", 4, lambda r: "ready"), SensorHandle("count", 4, lambda r: "ready")
    sc.attach("a", "count", a)
    sc.attach("b", "count", b)
    assert sc.drop_resource("count") == ["a", "b"] and a.detached and b.detached
    sc.forget("c")                                   # someone else gone: a's and b's kept
    sc.restore("a", "count")
    assert not a.detached and b.detached
    sc.restore("b", "count")                         # b's handle was kept while a came back
    assert not b.detached and sc.attached_to("count") == ["a", "b"]
    assert sc._parked == {}
    sc.route("count", sample(1))
    assert (a.received, b.received) == (1, 1)


def test_the_actuator_connection_refuses_a_sender_without_the_command_level():
    class Rs:
        def __init__(self):
            self.host = self

        def granted(self, who, resource):
            return Level.command if who == "ok" else Level.read

        def host_of(self, resource):
            return self

        def command(self, sender, resource, command, timeout):
            return (sender, resource, command, timeout)

    ac = ActuatorConnection(Rs())
    assert ac.command("ok", "arm", 1, 0.5) == ("ok", "arm", 1, 0.5)
    with pytest.raises(Refused) as err:
        ac.command("reader", "arm", 1, 0.5)
    assert err.value.message == "behavior 'reader' is not registered to command 'arm'"
    assert (ac.routed, ac.refused) == (1, 1)
    assert ac.command("reader", "arm", 2, 0.5, direct=True) == ("reader", "arm", 2, 0.5)
    assert (ac.routed, ac.refused) == (2, 1)
    with pytest.raises(Refused):
        ac.command("reader", "arm", 3, 0.5)
    assert (ac.routed, ac.refused) == (2, 2)          # each refusal counted


def test_a_slots_counters_are_read_and_counted_under_its_lock():
    """counters() is one moment's copy: it waits for the lock that report() and count()
    take (a driver's own thread reports while the host thread counts), so it never sees
    a sample counted without its number, nor a counter being added."""
    from esair_std.hosts.resource_host import Slot

    slot = Slot(None, "arm", object(), {})
    slot.count("expired")
    slot.count("expired")
    assert slot.counters() == {"reported": 0, "commands": 0, "command_errors": 0,
                               "polls_late": 0, "expired": 2, "seq": 0, "state": "ready"}
    out: list = []
    for read in (slot.counters, lambda: slot.count("commands")):
        with slot._lock:
            t = threading.Thread(target=lambda read=read: out.append(read()))
            t.start()
            t.join(0.2)
            assert t.is_alive()            # waits for the lock
        t.join(10.0)
        assert not t.is_alive()
    assert slot.counters()["commands"] == 1
