"""Reactions: resident, direct access to their declared resources, enabled/disabled by
behaviors; the example robot in both modes."""

from tests.support.std import call, wait_for

DEP = {
    "resources": {
        "count": {"class": "tests.support.comps:Counter", "rate": 400, "allow": {}},
        "rec": {"class": "tests.support.comps:Recorder", "allow": {}},
    },
    "reactions": {"guard": {"class": "tests.support.comps:Guard", "resources": ["count", "rec"]}},
    "behaviors": {"probe": {"class": "tests.support.comps:Probe"}},
}


def commands(rt):
    return rt.inspect("rec")["counters"]["commands"]


def test_reaction_reaches_resources_without_registration(start):
    rt = start(DEP)
    wait_for(lambda: commands(rt) >= 3, what="the guard commanding")
    assert rt.ls()[0]["kind"] == "reaction"
    # a behavior without a grant cannot do what the reaction does
    assert call(rt, "probe", "attach_actuator", "rec")["error"] == "Refused"


def test_behavior_disables_and_enables_a_reaction(start):
    rt = start(DEP)
    wait_for(lambda: commands(rt) >= 1, what="the guard commanding")
    assert call(rt, "probe", "disable_reaction", "guard") == {"ok": None}
    n = commands(rt)
    wait_for(lambda: rt.inspect("count")["counters"]["seq"] > 200, what="samples")
    assert commands(rt) <= n + 1          # at most a step that was already running
    assert call(rt, "probe", "enable_reaction", "guard") == {"ok": None}
    wait_for(lambda: commands(rt) > n + 2, what="the guard again")
    assert call(rt, "probe", "enable_reaction", "gaurd") == {
        "error": "ControlError", "message": "no reaction 'gaurd' (did you mean 'guard'?)"}


def test_reaction_takes_no_data(start):
    rt = start(DEP)
    assert call(rt, "probe", "put", "guard", 1, 0.2) == {"ok": False}
