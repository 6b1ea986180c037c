"""Resource Supervisor: deploy, add/remove with detach notices, registration by level,
configure checked against registration."""

import pytest
from tests.support.std import call, wait_for

from esair_std.errors import ComponentError, ControlError, Refused

DEP = {
    "resources": {
        "count": {"class": "tests.support.comps:Counter", "rate": 100, "allow": {"*": "read"}},
        "rec": {"class": "tests.support.comps:Recorder",
                "allow": {"probe": "command", "tuner": "configure", "p*": "read"}},
    },
    "behaviors": {
        "probe": {"class": "tests.support.comps:Probe", "uses": {"count": "read", "rec": "command"}},
        "tuner": {"class": "tests.support.comps:Probe", "uses": {"rec": "configure"}},
        "nouse": {"class": "tests.support.comps:Probe"},
    },
}


def test_registration_grants_within_uses_and_allow(start):
    rt = start(DEP)
    assert call(rt, "probe", "attach_sensor", "count") == {"ok": "ready"}
    assert call(rt, "probe", "attach_actuator", "rec") == {"ok": "ready"}
    assert call(rt, "probe", "send", "rec", {"a": 1}) == {"ok": {"n": 1, "gain": 1}}
    assert rt.inspect("rec")["grants"] == {"probe": "command"}


@pytest.mark.parametrize("who,do,res,message", [
    ("nouse", "attach_sensor", "count", "behavior 'nouse' does not list 'count' in its uses"),
    ("tuner", "attach_sensor", "count", "behavior 'tuner' does not list 'count' in its uses"),
    ("probe", "attach_sensor", "cuont", "no resource 'cuont' (did you mean 'count'?)"),
    ("tuner", "attach_actuator", "rec", None),
])
def test_registration_refusals_name_the_reason(start, who, do, res, message):
    rt = start(DEP)
    out = call(rt, who, do, res)
    if message is None:
        assert out == {"ok": "ready"}
    else:
        assert out == {"error": "Refused", "message": message}


def test_level_beyond_allow_is_refused(start):
    # The loader refuses a file whose uses exceed allow; a behavior added at run time is
    # refused the same way when it is added (issue 20), and the RS checks each
    # registration against the resource's allow as well.
    rt = start({"resources": DEP["resources"]})
    with pytest.raises(Refused) as exc:
        rt.add("pete", "tests.support.comps:Probe", uses={"rec": "command"})
    assert str(exc.value) == ("behavior 'pete' uses 'rec' at level 'command', but resource "
                              "'rec' allows it only up to 'read'")
    assert rt.state("pete") is None
    rt.add("pete", "tests.support.comps:Probe", uses={"rec": "read"})
    assert call(rt, "pete", "attach_actuator", "rec") == {
        "error": "Refused",
        "message": "behavior 'pete' lists 'rec' for read in its uses, not command"}
    assert call(rt, "pete", "configure", "rec", "gain", 2) == {
        "error": "Refused", "message": "behavior 'pete' is not registered for 'rec'"}


def test_level_beyond_uses_is_refused(start):
    dep = {"resources": DEP["resources"],
           "behaviors": {"probe": {"class": "tests.support.comps:Probe", "uses": {"rec": "read"}}}}
    rt = start(dep)
    assert call(rt, "probe", "attach_actuator", "rec") == {
        "error": "Refused",
        "message": "behavior 'probe' lists 'rec' for read in its uses, not command"}


def test_configure_checked_against_level(start):
    rt = start(DEP)
    assert call(rt, "probe", "attach_actuator", "rec") == {"ok": "ready"}
    assert call(rt, "probe", "configure", "rec", "gain", 3) == {
        "error": "Refused",
        "message": "behavior 'probe' is registered for command on 'rec': configure needs "
                   "the configure level"}
    with pytest.raises(Refused) as exc:
        rt.add("pete", "tests.support.comps:Probe", uses={"r*": "configure"})
    assert str(exc.value) == ("behavior 'pete' uses 'r*' at level 'configure', but resource "
                              "'rec' allows it only up to 'read'")
    assert call(rt, "tuner", "register", "rec", "configure") == {"ok": "configure"}
    assert call(rt, "tuner", "configure", "rec", "gain", 3) == {"ok": 3}
    assert call(rt, "probe", "send", "rec", "x") == {"ok": {"n": 1, "gain": 3}}
    assert call(rt, "tuner", "configure", "rec", "colour", 3) == {
        "error": "CommandError", "message": "rec: no setting 'colour' (settings: gain)"}
    # the operator (control CLI) is not a behavior: no registration needed
    assert rt.configure("rec", "gain", 5) == 5


def test_remove_resource_detaches_and_behaviors_keep_running(start):
    rt = start(DEP)
    assert call(rt, "probe", "attach_sensor", "count") == {"ok": "ready"}
    assert call(rt, "probe", "attach_actuator", "rec") == {"ok": "ready"}
    assert rt.remove_resource("rec") == ["probe"]
    assert rt.state("rec") is None
    assert call(rt, "probe", "handle_state", "rec") == {"ok": "detached"}
    assert call(rt, "probe", "send", "rec", 1) == {
        "error": "ResourceLost", "message": "rec: detached: the resource was removed"}
    assert rt.state("probe") == "running"
    wait_for(lambda: rt.get("probe") == {"notices": ["rec"]},
             what="detach notice")
    latest = wait_for(lambda: call(rt, "probe", "latest", "count")["ok"], what="a sample")
    assert latest[2] == "count"
    with pytest.raises(ControlError) as e:
        rt.remove_resource("rec")
    assert str(e.value) == "no resource 'rec'"


def test_add_resource_at_run_time_and_bad_ones(start):
    rt = start(DEP)
    kids = rt.add_resource("pair", "tests.support.comps:Pair", allow={"probe": "read"})
    assert kids == {"pair.count": "sensor", "pair.rec": "actuator"}
    assert rt.state("pair.count") == "ready"
    before = [(r["name"], r["state"]) for r in rt.ls()]
    with pytest.raises(ComponentError) as e:
        rt.add_resource("bad", "tests.support.comps:BadOpen")
    assert str(e.value) == ("resource 'bad' failed to open: "
                            "OSError: no such device /dev/nothing")
    with pytest.raises(ControlError) as e:
        rt.add_resource("count", "tests.support.comps:Counter")
    assert str(e.value) == "a resource named 'count' is already deployed"
    with pytest.raises(ControlError) as e:
        rt.remove_resource("pair.rec")
    assert str(e.value) == "'pair.rec' is part of 'pair': remove 'pair'"
    assert [(r["name"], r["state"]) for r in rt.ls()] == before


def test_deploy_fails_cleanly_when_a_resource_cannot_open(mode, start):
    with pytest.raises(ComponentError) as e:
        start({"resources": {"bad": {"class": "tests.support.comps:BadOpen"}},
               "behaviors": {"s": {"class": "tests.support.comps:Sink"}}})
    assert str(e.value) == "resource 'bad' failed to open: OSError: no such device /dev/nothing"


def test_unknown_configure_target(start):
    rt = start(DEP)
    with pytest.raises(Exception) as e:
        rt.configure("nothing", "k", 1)
    assert str(e.value) == "nothing: no such resource"
    assert isinstance(e.value, (Refused, Exception))


def test_no_setting_lists_the_settings_or_says_there_are_none():
    """The "no setting" error names what configure() takes (the class's ``settings``),
    says when there is none, and says when a class that overrides configure() did not
    declare its settings."""
    from types import SimpleNamespace

    from esair_std.errors import CommandError
    from esair_std.resource import Actuator, Sensor

    class Fan(Actuator):
        pass

    class Knob(Actuator):
        def configure(self, key, value):
            return value if key == "turn" else super().configure(key, value)

    class Dial(Knob):
        settings = ("turn",)

    said = []
    for cls in (Fan, Knob, Dial, Sensor):
        agent = cls()
        agent._esair = SimpleNamespace(name="x")
        with pytest.raises(CommandError) as err:
            agent.configure("gain", 2)
        said.append(str(err.value))
    assert said == ["x: no setting 'gain' (it has no settings)",
                    "x: no setting 'gain' (its class declares no settings)",
                    "x: no setting 'gain' (settings: turn)",
                    "x: no setting 'gain' (settings: rate_hz)"]
