"""An agent process leaves when its runtime is gone: the runtime's liveliness token
going away is taken as a hint and confirmed by asking the runtime (``ping``) first. In a
mesh of peers the token's withdrawal can also come when another peer's link drops (the
robot's radio, tests/net/test_starfish_net.py), while the agent's own link to the runtime
stays up: an agent on the robot must not leave then."""

from __future__ import annotations

from esair_std import Runtime
from esair_std.hosts import agent_process as agent_mod
from esair_std.spec import Spec
from esair_std.transport.bus import Bus
from tests.support.std import free_endpoint, wait_for


def test_an_agent_leaves_only_when_the_runtime_does_not_answer():
    ep = free_endpoint()
    rt = Runtime({"robot": "tokenbot", "mode": "thread"}, mode="thread", endpoint=ep,
                 control=True)
    rt.start()
    bus = Bus(connect=[ep])
    try:
        a = agent_mod.Agent(bus, "tokenbot", Spec("behavior", "b", "x:Y", {}, None), 1)
        wait_for(lambda: a._runtime_answers(), 20, what="the runtime's ping")
        lost = {"t": 1.0}                      # the token went away RUNTIME_GRACE ago
        a._runtime_gone(lost)
        assert not a.done.is_set() and a.token_doubts == 1
        wait_for(lambda: a.token_doubts >= 2, 20, what="a second ask while the token is away")
        assert not a.done.is_set()
        lost["t"] = None                       # the token is back: no more asking
        rt.stop()
        lost2 = {"t": 2.0}
        a._runtime_gone(lost2)                 # now nobody answers: it leaves
        assert a.done.is_set()
    finally:
        bus.close()
        rt.stop()


def test_an_agent_of_another_robot_is_not_kept_by_this_runtime():
    ep = free_endpoint()
    with Runtime({"robot": "tokenbot", "mode": "thread"}, mode="thread", endpoint=ep,
                 control=True):
        bus = Bus(connect=[ep])
        try:
            a = agent_mod.Agent(bus, "otherbot", Spec("behavior", "b", "x:Y", {}, None), 1)
            a._runtime_gone({"t": 1.0})
            assert a.done.is_set() and a.token_doubts == 0
        finally:
            bus.close()
