"""The HMI's side of the runtime (esair_std/hmi/bridge.py), without a browser: it asks
``ls`` when the runtime's notice says a state changed (not on a clock), and asks a
behavior's ``get`` only while a page shows it. Both modes."""

from __future__ import annotations

import pytest

from esair_std import Runtime
from esair_std.deploy.bundled import EXAMPLES
from esair_std.hmi import bridge as bridge_mod
from esair_std.hmi.bridge import Bridge
from esair_std.transport import keys
from esair_std.transport.bus import Bus
from tests.support.std import free_endpoint, wait_for


@pytest.fixture(params=["thread", "process"])
def lab(request):
    with Runtime(EXAMPLES / "lab" / "lab.yaml", mode=request.param, endpoint=free_endpoint(),
                 control=True) as rt:
        yield rt


def test_a_state_change_is_noticed_and_the_bridge_asks_ls_then(lab, monkeypatch):
    # no ls on a clock: the rows can only follow the runtime through its notices
    monkeypatch.setattr(bridge_mod, "LS_SAFETY_S", 3600.0)
    notices: list = []
    listener = Bus(connect=[lab.endpoint])
    listener.subscribe(keys.changed(lab.robot), notices.append)
    got: list[dict] = []
    b = Bridge(lab.endpoint, got.append, session_options={})
    b.showing = lambda: False
    b.start()
    try:
        asked = b.c["ls"]
        lab.add("sink", "tests.support.comps:Sink")
        wait_for(lambda: any(r["name"] == "sink" and r["state"] == "running" for r in b.rows),
                 timeout=30, what="sink running in the bridge's rows")
        assert b.c["notices"] >= 1 and b.c["ls"] > asked
        assert any(m["t"] == "log" and m["text"].startswith("sink: added") for m in got)
        assert notices and all(set(n) == {"v"} and isinstance(n["v"], int) for n in notices)
        assert b.c["gets"] == 0                       # no page shows the states
        b.showing = lambda: True
        wait_for(lambda: "sink" in b.states, timeout=30, what="sink's state asked for")
        assert b.states["sink"]["got"] == []
        lab.remove("sink")
        wait_for(lambda: all(r["name"] != "sink" for r in b.rows), timeout=30,
                 what="sink gone from the bridge's rows")
        assert any(m["t"] == "log" and m["text"] == "sink: removed" for m in got)
    finally:
        b.close()
        listener.close()
