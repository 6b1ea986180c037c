"""Another runtime of the same robot name on the network (a stray: a second `esair std
run lab`, or a program that took a port the robot had before) never answers for the
runtime at the endpoint a client, the HMI or an agent was given.

Found by CI: `esair std inspect logge` once answered "no component 'logge'" from another
runtime named lab that had joined the network; by hand, 2 of 6 `inspect` answered from
such a stray before the fix."""

from __future__ import annotations

import json

import pytest
import zenoh

from esair_std.cli.client import Client
from esair_std.errors import ControlError
from esair_std.transport.bus import Bus
from esair_std.transport.session import open_session
from tests.support.std import MODES, free_endpoint, lab_started, std_run, wait_for

pytestmark = pytest.mark.slow
STRAY = "no component 'logge' (answered by the stray)"


@pytest.fixture(scope="module", params=MODES)
def lab_and_stray(request):
    """The lab robot at ``ep``, and a stray Zenoh peer linked to it that answers every
    control request of robot 'lab' at once: (ep, the stray's Zenoh id)."""
    ep = free_endpoint()
    with std_run("lab", request.param, ep, lambda: lab_started(ep)):
        stray = open_session(listen=["tcp/127.0.0.1:0"], connect=[ep])
        try:
            def answer(query):
                query.reply(query.key_expr, json.dumps(
                    {"ok": {"robot": "lab"}} if str(query.key_expr).endswith("/ping")
                    else {"error": STRAY, "type": "ControlError"}).encode())
            q = stray.declare_queryable("esair/lab/ctl/*",
                                        zenoh.handlers.Callback(answer, indirect=False))
            yield ep, str(stray.info.zid())
            q.undeclare()
        finally:
            stray.close()


def _answerers(bus: Bus, key: str) -> set[str]:
    """The Zenoh ids of every peer that answers ``key`` (all replies, unfiltered)."""
    out = set()
    for reply in bus.session.get(key, payload=b"{}", timeout=2.0):
        if reply.ok is not None and reply.replier_id is not None:
            out.add(str(reply.replier_id.zid))
    return out


def test_the_command_line_client_hears_only_the_runtime_it_was_given(lab_and_stray):
    ep, _ = lab_and_stray
    for _ in range(6):                  # a new session each time, as each command opens
        with Client(ep) as c:
            assert c.robot == "lab"
            with pytest.raises(ControlError) as exc:
                c.call("inspect", {"name": "logge"})
            assert str(exc.value) == "no component 'logge' (did you mean 'logger'?)"


def test_a_session_that_meets_the_stray_takes_no_answer_from_it(lab_and_stray):
    """The HMI's and a remote agent's bus: it listens and takes peers from gossip, so it
    is linked to the stray too, which answers it; its control requests still count the
    runtime's answer only, and the stray's are counted as ignored."""
    ep, stray = lab_and_stray
    bus = Bus(connect=[ep], runtime=ep)
    try:
        # the hazard is real: the stray is reached and answers this session
        wait_for(lambda: stray in _answerers(bus, "esair/lab/ctl/inspect"), timeout=20,
                 what="the stray answering this session")
        for _ in range(10):
            r = bus.request("esair/lab/ctl/inspect", {"name": "logge"}, 5.0)
            assert r == {"error": "no component 'logge' (did you mean 'logger'?)",
                         "type": "ControlError"}
            assert bus.request("esair/*/ctl/ping", {}, 5.0)["ok"]["robot"] == "lab"
    finally:
        bus.close()


def test_the_hmi_shows_the_stray_answers_it_ignored(lab_and_stray):
    """The HMI's bridge asks the runtime every second; the stray's answers it ignores
    are counted where a user sees them (`/status.json`, bridge.foreign_answers), and
    what it shows is the runtime's: the lab's components, not the stray's error."""
    from esair_std.hmi.bridge import Bridge
    ep, _ = lab_and_stray
    bridge = Bridge(ep, lambda msg: None)
    bridge.start()
    try:
        wait_for(lambda: bridge.counters()["foreign_answers"] > 0, timeout=30,
                 what="a stray answer counted")
        assert bridge.robot == "lab" and "logger" in {r["name"] for r in bridge.rows}
        assert bridge.counters()["ls_failed"] == 0
    finally:
        bridge.close()
