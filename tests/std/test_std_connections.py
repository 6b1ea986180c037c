"""SC: every sample to every attached behavior (numbered), overwrites counted, nothing
kept for nobody. AC: commands routed, errors raised to the sender, no arbitration."""

import os
import signal
import time

from esair_std.transport.security_config import LEASE_MS
from tests.support.std import call, wait_for

DEP = {
    "resources": {
        "count": {"class": "tests.support.comps:Counter", "rate": 400, "allow": {"*": "read"}},
        "rec": {"class": "tests.support.comps:Recorder", "allow": {"*": "command"}},
    },
    "behaviors": {
        "w1": {"class": "tests.support.comps:Watcher", "uses": {"count": "read"}},
        "w2": {"class": "tests.support.comps:Watcher", "uses": {"count": "read"}},
        "w3": {"class": "tests.support.comps:Watcher", "uses": {"count": "read"}},
        "slow": {"class": "tests.support.comps:Watcher", "uses": {"count": "read"}, "period": 0.05,
                 "keep": 4, "slow": 0.03},
    },
}


def test_every_sample_reaches_every_attached_behavior(start):
    rt = start(DEP)
    wait_for(lambda: all(rt.get(w)["n"] >= 100 for w in ("w1", "w2", "w3")),
             what="100 samples each")
    for w in ("w1", "w2", "w3"):
        got = rt.get(w)
        assert got["gaps"] == 0 and got["overwritten"] == 0, (w, got)
        assert got["last"] - got["first"] + 1 == got["n"]
    # the slow one cannot keep up: its overwrites are counted, not silent
    # (a drop shows as a gap at the slow one's next samples() call)
    slow = wait_for(lambda: (lambda g: g if g["overwritten"] > 0 and g["gaps"] > 0
                             else None)(rt.get("slow")), what="overwrites")
    assert slow["gaps"] <= slow["overwritten"]
    c = rt.inspect("slow")["counters"]["sensor:count"]
    assert c["overwritten"] >= slow["overwritten"] and c["received"] > slow["n"]
    assert rt.inspect("count")["attached"] == ["slow", "w1", "w2", "w3"]


def test_samples_that_never_reached_a_behavior_are_counted(start, mode):
    """Every sample the sensor numbered after a behavior's first is read by it, pushed out
    of its handle (overwritten) or counted as missed: never reached it (process mode: its
    process stopped longer than the link lease, its links dropped as a silent
    computer's). Thread mode has no link: nothing is missed."""
    rt = start({"resources": {"count": {"class": "tests.support.comps:Counter", "rate": 50,
                                        "allow": {"*": "read"}}},
                "behaviors": {"w": {"class": "tests.support.comps:Watcher",
                                    "uses": {"count": "read"}}}})
    wait_for(lambda: rt.get("w")["n"] >= 20, what="20 samples")
    if mode == "process":
        pid = next(r["pid"] for r in rt.ls() if r["name"] == "w")
        os.kill(pid, signal.SIGSTOP)
        try:
            time.sleep(2.5 * LEASE_MS / 1000)      # the fault: silent past the lease
        finally:
            os.kill(pid, signal.SIGCONT)
    after = rt.inspect("count")["counters"]["seq"] + 50
    got = wait_for(lambda: (lambda g: g if g["last"] >= after else None)(rt.get("w")),
                   what="samples after the stop", timeout=30)
    assert got["overwritten"] == 0
    assert got["unread"] == got["missed"], got
    assert got["last"] - got["first"] + 1 == got["n"] + got["missed"]
    assert rt.inspect("w")["counters"]["sensor:count"]["missed"] >= got["missed"]
    if mode == "process":
        assert got["missed"] > 0, got
    else:
        assert got["missed"] == 0, got


def test_nothing_kept_for_nobody(start):
    rt = start({"resources": DEP["resources"],
                "behaviors": {"probe": {"class": "tests.support.comps:Probe", "uses": {"count": "read"}}}})
    wait_for(lambda: rt.inspect("count")["counters"]["seq"] > 20, what="samples")
    assert call(rt, "probe", "attach_sensor", "count") == {"ok": "ready"}
    first = wait_for(lambda: call(rt, "probe", "latest", "count")["ok"], what="a sample")
    assert first[0] > 20          # what was reported before attaching was not kept


def test_actuator_commands_errors_and_no_arbitration(start):
    rt = start({"resources": DEP["resources"],
                "behaviors": {"a": {"class": "tests.support.comps:Probe", "uses": {"rec": "command"}},
                              "b": {"class": "tests.support.comps:Probe", "uses": {"rec": "command"}}}})
    assert call(rt, "a", "attach_actuator", "rec") == {"ok": "ready"}
    assert call(rt, "b", "attach_actuator", "rec") == {"ok": "ready"}
    assert call(rt, "a", "send", "rec", 1) == {"ok": {"n": 1, "gain": 1}}
    assert call(rt, "b", "send", "rec", 2) == {"ok": {"n": 2, "gain": 1}}
    assert call(rt, "a", "send", "rec", {"fail": "too far"}) == {
        "error": "CommandError", "message": "rec: ValueError: too far"}
    assert call(rt, "b", "send", "rec", 3) == {"ok": {"n": 3, "gain": 1}}


def test_lost_actuator_fails_at_once_then_ready_again(start):
    rt = start({"resources": DEP["resources"],
                "behaviors": {"a": {"class": "tests.support.comps:Probe", "uses": {"rec": "command"}}}})
    assert call(rt, "a", "attach_actuator", "rec") == {"ok": "ready"}
    assert call(rt, "a", "send", "rec", {"lost": "cable out"}) == {"ok": "marking lost"}
    wait_for(lambda: rt.state("rec") == "lost", what="lost")
    assert call(rt, "a", "handle_state", "rec") == {"ok": "lost"}
    assert call(rt, "a", "send", "rec", 1) == {
        "error": "ResourceLost", "message": "rec: lost: cable out"}
    assert [r["reason"] for r in rt.ls() if r["name"] == "rec"] == ["cable out"]
    assert call(rt, "a", "send", "rec", 1, 0.5)["error"] == "ResourceLost"
