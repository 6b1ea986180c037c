"""STD's wire in one place (transport/wire.py): every error class survives the trip word
for word, every endpoint answers a verb it does not know with one clear error, and the
CLI raises (and prints) the class an agent raised; in both modes."""

import pytest
from tests.support.std import MODES, agent_children, esair, free_endpoint

from esair_std import Runtime
from esair_std.cli.client import Client
from esair_std.drivers.minlink.link_errors import LinkDown
from esair_std.errors import (CommandError, ComponentError, ControlError, DeployError, Refused,
                              ResourceLost, StdError, TransportError)
from esair_std.transport import codec, wire
from esair_std.transport.bus import Bus
from esair_std.transport.tls_certs import CertError
from esair_min.errors import Mark

DEP = {
    "robot": "w",
    "resources": {
        "rec": {"class": "tests.support.comps:Recorder",
                "allow": {"probe": "configure", "operator": "configure"}},
    },
    "behaviors": {
        "probe": {"class": "tests.support.comps:Probe", "uses": {"rec": "configure"}},
    },
}

CASES = [
    StdError("something went wrong"),
    Refused("behavior 'x' does not list 'rec' in its uses"),
    CommandError("rec", "speed 99 out of range 1-9"),
    ResourceLost("rec", "lost: unplugged"),
    ComponentError("module 'lab' has no class 'Nope'"),
    ControlError("unknown control verb 'x'"),
    TransportError("message is not JSON: nested too deeply"),
    DeployError("'rate' must be a number", Mark("lab.yaml", 3, 7)),
]


def _trip(reply):
    """A reply after the wire: JSON bytes and back."""
    return codec.decode(codec.encode(reply))


def test_every_error_class_of_the_wire_has_a_case():
    assert sorted(type(e).__name__ for e in CASES) == sorted(wire.ERRORS)


@pytest.mark.parametrize("exc", CASES, ids=lambda e: type(e).__name__)
def test_every_error_class_round_trips_word_for_word(exc):
    reply = _trip(wire.error(exc))
    assert reply["type"] == type(exc).__name__ and reply["error"] == str(exc)
    with pytest.raises(StdError) as got:
        wire.result(reply)
    assert type(got.value) is type(exc)
    assert str(got.value) == str(exc)
    if isinstance(exc, (CommandError, ResourceLost)):
        assert (got.value.resource, got.value.reason) == (exc.resource, exc.reason)
        assert reply == {"error": str(exc), "type": type(exc).__name__,
                         "resource": exc.resource, "reason": exc.reason}
    else:
        assert reply == {"error": str(exc), "type": type(exc).__name__}


def test_other_errors_travel_as_their_nearest_wire_class():
    reply = _trip(wire.error(CertError("ca.pem: not a certificate")))
    assert reply == {"error": "ca.pem: not a certificate", "type": "StdError"}
    assert type(wire.exception(reply)) is StdError
    # no StdError at all (a bug, a link's own error): an internal error, never lost
    reply = _trip(wire.error(LinkDown("port closed")))
    assert reply == {"error": "internal error: LinkDown: port closed", "type": "StdError"}
    assert str(wire.exception(reply)) == "internal error: LinkDown: port closed"


def test_a_short_or_unknown_error_reply_decodes_to_one_class():
    # a CommandError that does not name its resource is the asker's resource's
    got = wire.exception({"error": "is a sensor: it takes no commands", "type": "CommandError"},
                         "count")
    assert (type(got), str(got)) == (CommandError, "count: is a sensor: it takes no commands")
    got = wire.exception({"error": "from the future", "type": "TimeTravelError"})
    assert (type(got), str(got)) == (StdError, "from the future")
    assert wire.result({"ok": [1, 2]}) == [1, 2]


def test_a_driver_failure_is_a_command_error_of_its_resource():
    assert str(wire.failure("command queue full", "arm")) == "arm: command queue full"
    lost = ResourceLost("arm", "removed")
    assert wire.failure(lost, "arm") is lost


def test_the_verb_table_answers_every_request_once():
    verbs = wire.Verbs(unknown="unknown op {verb!r}")
    verbs.add("echo", lambda b: b["x"])
    verbs.add("boom", lambda b: 1 / 0)
    verbs.add("refuse", lambda b: (_ for _ in ()).throw(Refused("not you")))
    later = []
    verbs.later("later", lambda b, answer: later.append(answer))
    out = []

    def serve(verb, body, error=""):
        got = []
        verbs.serve(verb, body, error, got.append)
        out.append(got)
    serve("echo", {"x": 3})
    serve("nope", {})
    serve(None, {})
    serve(7, {})
    serve("echo", None, "request is not a JSON object")
    serve("echo", {})
    serve("boom", {})
    serve("refuse", {})
    serve("later", {})
    assert out == [
        [{"ok": 3}],
        [{"error": "unknown op 'nope'", "type": "ControlError"}],
        [{"error": "unknown op None", "type": "ControlError"}],
        [{"error": "unknown op 7", "type": "ControlError"}],
        [{"error": "bad request: request is not a JSON object", "type": "ControlError"}],
        [{"error": "internal error: KeyError: 'x'", "type": "StdError"}],
        [{"error": "internal error: ZeroDivisionError: division by zero", "type": "StdError"}],
        [{"error": "not you", "type": "Refused"}],
        [],
    ]
    later[0](wire.ok("done"))
    assert out[-1] == [{"ok": "done"}]
    assert verbs.c == {"bad_requests": 4}
    assert verbs.names() == ["boom", "echo", "later", "refuse"]


@pytest.fixture(scope="module", params=MODES)
def robot(request):
    """One robot per mode with its control endpoint: (runtime, endpoint, mode)."""
    ep = free_endpoint()
    rt = Runtime(DEP, mode=request.param, endpoint=ep, control=True)
    rt.start()
    try:
        rt.wait_state("probe", "running")
        yield rt, ep, request.param
    finally:
        rt.stop()
    assert agent_children() == [], "agent processes left behind"


def _ask(ep, key, body):
    """Every reply to one query (a list: an endpoint answers once)."""
    bus = Bus(connect=[ep])
    try:
        bus.route(key).ready.wait(5.0)
        got = bus.session.get(key, payload=codec.encode(body), timeout=5.0)
        return [codec.decode(r.ok.payload.to_bytes()) for r in got if r.ok is not None]
    finally:
        bus.close()


def test_an_unknown_verb_gets_one_clear_error_from_every_endpoint(robot):
    rt, ep, mode = robot
    assert _ask(ep, "esair/w/ctl/frobnicate", {}) == [
        {"error": "unknown control verb 'frobnicate'", "type": "ControlError"}]
    if mode == "process":      # the agents' endpoints: bs/<behavior>, rs/<resource entry>
        for key in ("esair/w/bs/probe", "esair/w/rs/rec"):
            assert _ask(ep, key, {"op": "frobnicate"}) == [
                {"error": "unknown op 'frobnicate'", "type": "ControlError"}], key
            assert _ask(ep, key, {}) == [
                {"error": "unknown op None", "type": "ControlError"}], key
        assert _ask(ep, "esair/w/bs/probe", {"op": "state"}) == [{"ok": "running"}]
    assert rt.state("probe") == "running" and rt.inspect("rec")["state"] == "ready"


def _probe(rt, do, *args):
    rt.put("probe", {"do": do, "args": list(args)}, timeout=5.0)
    return rt.get("probe", timeout=5.0)


def test_the_cli_raises_and_prints_what_the_agent_raised(robot):
    rt, ep, mode = robot
    # rec's configure() raises CommandError("rec", "no setting 'nosuch' (settings: gain)")
    # in its host (an agent process in process mode); the behavior, the runtime's API and
    # the CLI all get that class with those words
    said = "rec: no setting 'nosuch' (settings: gain)"
    assert _probe(rt, "register", "rec", "configure") == {"ok": "configure"}
    assert _probe(rt, "configure", "rec", "nosuch", 1) == {"error": "CommandError",
                                                            "message": said}
    with pytest.raises(CommandError) as at_runtime:
        rt.configure("rec", "nosuch", 1)
    with Client(ep) as c, pytest.raises(CommandError) as at_cli:
        c.call("configure", {"resource": "rec", "key": "nosuch", "value": 1})
    for got in (at_runtime.value, at_cli.value):
        assert (str(got), got.resource, got.reason) == (said, "rec", "no setting 'nosuch' (settings: gain)")
    r = esair("configure", "rec", "nosuch", "1", "-e", ep, check=False)
    assert (r.returncode, r.stdout, r.stderr) == (1, "", f"error: {said}\n")
    # a component that cannot start: ComponentError on both sides, word for word
    with pytest.raises(ComponentError) as at_runtime:
        rt.add("x", "tests.support.comps:Nope")
    with Client(ep) as c, pytest.raises(ComponentError) as at_cli:
        c.call("add", {"name": "x", "class": "tests.support.comps:Nope"})
    assert str(at_cli.value) == str(at_runtime.value) == (
        "module 'tests.support.comps' has no class 'Nope'")
