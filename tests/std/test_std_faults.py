"""Faults never spread: a behavior that raises or overruns is failed and restarted by
its policy; the others lose no sample and no put (sequence numbers prove it)."""

import pytest
from tests.support.std import wait_for

BASE = {
    "resources": {"count": {"class": "tests.support.comps:Counter", "rate": 200, "allow": {"*": "read"}}},
    "behaviors": {
        "sink": {"class": "tests.support.comps:Sink"},
        "pusher": {"class": "tests.support.comps:Pusher", "options": {}},
        "watch": {"class": "tests.support.comps:Watcher", "uses": {"count": "read"}},
    },
}


def with_faulty(fail, restart=None):
    dep = {k: dict(v) for k, v in BASE.items()}
    f = {"class": "tests.support.comps:Faulty", "fail": fail, "uses": {"count": "read"}, "deadline": 0.3}
    if restart:
        f["restart"] = restart
    dep["behaviors"]["faulty"] = f
    return dep


def assert_others_lost_nothing(rt):
    pushed = rt.get("pusher")
    got = rt.get("sink")["got"]
    assert pushed["failed"] == 0
    assert [d["n"] for _s, d in got] == list(range(1, len(got) + 1))
    assert len(got) >= pushed["ok"] - 1          # one put may be in flight
    w = rt.get("watch")
    assert w["gaps"] == 0 and w["overwritten"] == 0


@pytest.mark.parametrize("fail,reason", [
    ("raise", "RuntimeError: boom"),
    ("hang", "step() ran over its 0.3 s deadline"),
    ("start", "RuntimeError: refuses to start"),
])
def test_failure_is_contained(start, fail, reason):
    rt = start(with_faulty(fail))
    wait_for(lambda: rt.state("faulty") == "failed", what="failed")
    row = [r for r in rt.ls() if r["name"] == "faulty"][0]
    assert row["reason"] == reason and row["restarts"] == 0
    wait_for(lambda: rt.get("pusher")["ok"] >= 30, what="30 puts")
    assert_others_lost_nothing(rt)
    assert rt.inspect("count")["attached"] == ["watch"]       # the failed one is detached


def test_restart_policy_then_stays_failed(start):
    rt = start(with_faulty("raise", {"max": 2, "within": 60}))
    wait_for(lambda: rt.inspect("faulty")["restarts"] == 2 and rt.state("faulty") == "failed",
             what="two restarts then failed")
    info = rt.inspect("faulty")
    assert info["reason"] == "RuntimeError: boom"
    wait_for(lambda: rt.get("pusher")["ok"] >= 20, what="20 puts")
    assert_others_lost_nothing(rt)


def test_a_failing_receive_fails_only_the_receiver(start):
    rt = start(with_faulty("none", {"max": 1, "within": 60}))
    pid = rt.get("faulty")["pid"]
    rt.put("faulty", "raise")
    wait_for(lambda: rt.inspect("faulty")["restarts"] == 1 and rt.state("faulty") == "running",
             what="restarted")
    assert rt.get("faulty")["steps"] >= 0
    if rt.mode_name == "process":
        assert rt.get("faulty")["pid"] != pid
    assert_others_lost_nothing(rt)


@pytest.mark.parametrize("mode", ["process"])      # a thread has no process to kill
def test_sigkilled_behavior_process_is_failed_and_restarted(start, mode):
    import os
    import signal
    rt = start(with_faulty("none", {"max": 1, "within": 60}))
    victim = [r for r in rt.ls() if r["name"] == "faulty"][0]["pid"]
    os.kill(victim, signal.SIGKILL)
    wait_for(lambda: rt.inspect("faulty")["restarts"] == 1 and rt.state("faulty") == "running",
             what="restart after SIGKILL")
    row = [r for r in rt.ls() if r["name"] == "faulty"][0]
    assert row["pid"] != victim
    wait_for(lambda: rt.get("pusher")["ok"] >= 20, what="20 puts")
    assert_others_lost_nothing(rt)
    os.kill(row["pid"], signal.SIGKILL)          # the policy allows one: now it stays failed
    wait_for(lambda: rt.state("faulty") == "failed", what="failed for good")
    assert rt.inspect("faulty")["reason"] in ("its process is gone (liveliness token lost)",
                                              "process exited with status -9")
    assert_others_lost_nothing(rt)
