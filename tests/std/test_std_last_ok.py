"""An actuator's last commands that went through (``last_ok`` in its counters, as
``inspect`` shows them): kept by its host whoever sent them, so an HMI started later
shows the pose the robot holds (docs/std.md, docs/hmi.md)."""

from __future__ import annotations

import time

import pytest

from esair_std import Runtime
from esair_std.hosts.resource_host import LAST_OK
from tests.support.std import call, free_endpoint

DEP = {"robot": "t",
       "resources": {"rec": {"class": "tests.support.comps:Recorder",
                             "allow": {"*": "command"}}},
       "behaviors": {"c": {"class": "tests.support.comps:Probe",
                           "uses": {"rec": "command"}}}}


@pytest.mark.parametrize("mode", ["thread", "process"])
def test_inspect_gives_an_actuators_last_commands_that_went_through(mode):
    rt = Runtime(DEP, mode=mode, endpoint=free_endpoint())
    rt.start()
    try:
        assert "last_ok" not in rt.inspect("rec")["counters"]        # none yet
        assert call(rt, "c", "attach_actuator", "rec") == {"ok": "ready"}
        before = time.time()
        sent = ["a", {"fail": "jam"}, "b", "c", {"refuse": "no"}, "d", "e"]
        answers = [call(rt, "c", "send", "rec", cmd) for cmd in sent]
        after = time.time()
        last = rt.inspect("rec")["counters"]["last_ok"]
        went = [(cmd, a["ok"]) for cmd, a in zip(sent, answers, strict=True) if "ok" in a]
        assert len(went) == 5 and LAST_OK == 4
        # the last LAST_OK that went through, oldest first, each with when and its answer;
        # the refused and failed ones are not there
        assert [(cmd, ok) for _, cmd, ok in last] == went[-LAST_OK:]
        times = [t for t, _, _ in last]
        assert times == sorted(times) and before <= times[0] and times[-1] <= after
    finally:
        rt.stop()
