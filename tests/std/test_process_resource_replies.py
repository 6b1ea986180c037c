"""The runtime's proxy of a resource in an agent process (modes/process.py,
ProcessResource) reads its host's replies as the wire says: an answer that is no JSON
object is ResourceLost, as no answer is, never an AttributeError reaching the behavior
that sent the command (ActuatorHandle.send raises only CommandError or ResourceLost)."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from esair_std.errors import CommandError, ResourceLost
from esair_std.modes.process import ProcessResource
from esair_std.spec import Spec
from esair_std.transport import keys
from esair_std.transport.bus import Bus
from tests.support.std import free_endpoint

ROBOT = "garbage-replies"


@pytest.fixture(scope="module")
def proxy():
    """A ProcessResource whose actuator key is answered by a queryable of the test's own
    (each command's ``cmd`` is the reply it gets), over a real Zenoh session."""
    bus = Bus(listen=[free_endpoint()])
    bus.serve(keys.actuator(ROBOT, "arm"),
              lambda req: req.reply(req.body["cmd"] if req.body is not None else None))
    mode = SimpleNamespace(bus=bus, rt=SimpleNamespace(robot=ROBOT), remote={})
    try:
        yield ProcessResource(mode, Spec("resource", "arm", "m:C"), 1)
    finally:
        bus.close()


@pytest.mark.parametrize("reply", [[1, 2], "ok", 3])
def test_a_reply_that_is_no_object_is_resource_lost(proxy, reply):
    with pytest.raises(ResourceLost, match="answered with no reply object"):
        proxy.command("b", "arm", reply, 2.0)


def test_an_object_reply_still_reads_as_the_wire_says(proxy):
    assert proxy.command("b", "arm", {"ok": 5}, 2.0) == 5
    with pytest.raises(CommandError, match="jammed"):
        proxy.command("b", "arm", {"error": "jammed", "type": "CommandError",
                                   "resource": "arm", "reason": "jammed"}, 2.0)
