"""Issue 20: `esair std` for an operator, against a running robot (the lab, in each
mode): errors in plain words, what the CLI promises, observing and commanding the robot.
Every message is asserted word for word. (A module of its own: the robot of each mode
runs while its tests run, and no longer.)"""

from __future__ import annotations

import json
import subprocess

import pytest

from tests.support import std
from tests.support.std import MODES, components, free_endpoint, lab_started, std_run, wait_for


@pytest.fixture(scope="module", params=MODES)
def lab(request):
    """The lab robot (`esair std run lab`) in each mode: (endpoint, mode)."""
    ep = free_endpoint()
    with std_run("lab", request.param, ep, lambda: lab_started(ep), "every component running"):
        yield ep, request.param


def esair(*args: str, stdin: str | None = None) -> subprocess.CompletedProcess:
    return std.esair(*args, check=False, stdin=stdin)


def error_of(*args: str) -> tuple[int, str]:
    r = esair(*args)
    return r.returncode, r.stderr


def test_a_port_in_use_is_said_in_plain_words(lab):
    ep, _ = lab
    assert error_of("run", "lab", "-e", ep, "--run", "1") == (
        1, f"error: {ep}: port in use, choose another with -e\n")


def test_inspect_has_a_did_you_mean(lab):
    ep, _ = lab
    assert error_of("inspect", "logge", "-e", ep) == (
        1, "error: no component 'logge' (did you mean 'logger'?)\n")
    assert error_of("inspect", "bench.tmp", "-e", ep) == (
        1, "error: no component 'bench.tmp' (did you mean 'bench.temp'?)\n")


def test_add_is_refused_when_allow_grants_less(lab):
    ep, _ = lab
    assert error_of("add", "spy", "lab:Logger", "--uses", "arm=command", "-e", ep) == (
        1, "error: behavior 'spy' uses 'arm' at level 'command', but resource 'arm' does "
           "not allow it (add 'spy: command' to its allow)\n")
    assert error_of("add", "spy", "lab:Logger", "--uses", "wave=configure", "-e", ep) == (
        1, "error: behavior 'spy' uses 'wave' at level 'configure', but resource 'wave' "
           "allows it only up to 'read'\n")
    assert error_of("add", "spy", "lab:Logger", "--uses", "wav=read", "-e", ep) == (
        1, "error: behavior 'spy' uses unknown resource 'wav' (did you mean 'wave'?)\n")
    assert "spy" not in [r["name"] for r in components(ep)]


def test_add_exits_1_when_start_raises(lab):
    ep, _ = lab
    assert error_of("add", "shaky", "tests.support.comps:Faulty", "-o", "fail=start", "-e", ep) == (
        1, "error: behavior 'shaky' did not start: RuntimeError: refuses to start\n")
    assert "shaky" not in [r["name"] for r in components(ep)]
    r = esair("add", "shaky", "tests.support.comps:Faulty", "-e", ep)       # the name is free again
    assert (r.returncode, r.stdout) == (0, "shaky: running\n")
    assert esair("remove", "shaky", "-e", ep).returncode == 0


def test_put_reads_data_from_a_file_or_stdin(lab, tmp_path):
    ep, _ = lab
    assert esair("add", "inbox", "lab:Logger", "-e", ep).returncode == 0
    try:
        big = list(range(40_000))                         # 229 KB of JSON
        path = tmp_path / "big.json"
        path.write_text(json.dumps(big))
        assert len(path.read_bytes()) > 131072            # more than one argument may hold
        r = esair("put", "inbox", "--file", str(path), "--timeout", "5", "-e", ep)
        assert (r.returncode, r.stdout) == (0, "delivered\n"), r.stderr
        got = json.loads(esair("get", "inbox", "-e", ep).stdout)
        assert got["last"] == {"from": "operator", "data": big}
        r = esair("put", "inbox", "-", "-e", ep, stdin='{"from": "stdin"}\n')
        assert (r.returncode, r.stdout) == (0, "delivered\n"), r.stderr
        got = json.loads(esair("get", "inbox", "-e", ep).stdout)
        assert got == {"received": 2, "last": {"from": "operator", "data": {"from": "stdin"}}}
        path.write_text(json.dumps(list(range(50_000))))  # 289 KB: over the message cap
        assert error_of("put", "inbox", "-f", str(path), "-e", ep) == (
            1, "error: DATA is 288891 bytes of JSON, more than one message carries "
               "(261120 bytes)\n")
        r = esair("put", "inbox", "-e", ep)
        assert (r.returncode, r.stderr.splitlines()[-1]) == (
            2, "Error: give DATA (or - for standard input), or --file FILE")
    finally:
        esair("remove", "inbox", "-e", ep)


def test_sample_reads_a_sensors_latest_sample(lab):
    ep, _ = lab
    r = esair("sample", "wave", "-e", ep)
    assert r.returncode == 0, r.stderr
    assert -1.0 <= json.loads(r.stdout) <= 1.0
    meta = json.loads(esair("sample", "ticks", "--meta", "-e", ep).stdout)
    assert meta["resource"] == "ticks" and meta["seq"] >= 1 and meta["value"] >= 0
    # the latest, not the first: a later sample comes (ticks counts at 20 Hz)
    wait_for(lambda: json.loads(esair("sample", "ticks", "--meta", "-e", ep).stdout)["seq"]
             > meta["seq"], what="a later sample of ticks")
    assert error_of("sample", "arm", "-e", ep) == (1, "error: 'arm' is an actuator, not a "
                                                      "sensor\n")
    assert error_of("sample", "bench", "-e", ep) == (
        1, "error: no sensor 'bench' ('bench' is a driver; its sensors: bench.temp)\n")
    assert error_of("sample", "wav", "-e", ep) == (
        1, "error: no sensor 'wav' (did you mean 'wave'?)\n")
    assert error_of("get", "wave", "-e", ep) == (
        1, "error: get from 'wave' failed: no behavior 'wave' (a sensor: read it with "
           "`esair std sample wave`)\n")


def test_send_commands_an_actuator_as_the_operator(lab):
    ep, _ = lab
    assert error_of("send", "arm", '{"angle": 10}', "-e", ep) == (
        1, "error: 'arm' does not allow the operator (add 'operator: command' to the allow "
           "of resource 'arm')\n")
    assert error_of("send", "bench.fan", "1", "-e", ep) == (
        1, "error: 'bench.fan' allows the operator only up to 'read' (add 'operator: "
           "command' to the allow of resource 'bench')\n")
    assert error_of("send", "wave", "1", "-e", ep) == (
        1, "error: 'wave' is a sensor, not an actuator\n")
    r = esair("add-resource", "pen", "esair_std.drivers.sim:Recorder", "--allow",
              "operator=command", "-e", ep)
    assert r.returncode == 0, r.stderr
    try:
        r = esair("send", "pen", '{"angle": 90}', "-e", ep)
        assert (r.returncode, r.stdout) == (0, '{"count": 1, "speed": 5}\n'), r.stderr
        assert error_of("send", "pen", '{"angle": 200}', "-e", ep) == (
            1, "error: pen: angle 200 out of range 0-180\n")
        info = json.loads(esair("inspect", "pen", "-e", ep).stdout)
        assert info["grants"] == {"operator": "command"}
    finally:
        esair("remove-resource", "pen", "-e", ep)


def test_ls_json_is_one_object_with_the_same_keys_for_every_component(lab):
    ep, mode = lab
    out = json.loads(esair("ls", "--json", "-e", ep).stdout)
    assert list(out) == ["robot", "endpoint", "starting", "stopped", "components"]
    assert out["stopped"] is None                  # not STOPPED (docs/std.md)
    assert (out["robot"], out["endpoint"], out["starting"]) == ("lab", ep, False)
    rows = {r["name"]: r for r in out["components"]}
    keys = ["name", "kind", "state", "pid", "host", "restarts", "reason", "class", "parent",
            "attached", "detached"]
    assert all(list(r) == keys for r in rows.values())
    assert list(rows) == ["guard", "logger", "follow", "tuner", "keeper", "wave", "ticks",
                          "arm", "bench", "bench.temp", "bench.fan"]
    assert (rows["bench"]["kind"], rows["bench"]["class"]) == (
        "driver", "esair_std.drivers.sim:Bench")
    assert rows["bench.fan"]["parent"] == "bench" and rows["arm"]["parent"] == ""
    wait_for(lambda: components(ep)[2]["attached"] == ["arm", "wave"],
             what="follow attached to wave and arm")
    rows = {r["name"]: r for r in json.loads(esair("ls", "--json", "-e", ep).stdout)[
        "components"]}
    assert "follow" in rows["wave"]["attached"]
    assert "follow" in rows["arm"]["attached"]           # an actuator's real attachments
    assert rows["logger"]["attached"] == []

