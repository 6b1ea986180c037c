"""The control CLI end to end: `esair std run` in one process, every control command
from other processes, garbage on the control endpoint; in both modes."""

import contextlib
import json
from pathlib import Path
import subprocess
import sys
import time

import pytest
from tests.support.std import (MODES, components, esair, free_endpoint, lab_started, processes,
                                std_cli, std_run, wait_for)

pytestmark = pytest.mark.slow

HERE = str(Path(__file__).resolve().parents[2])  # the checkout


@pytest.fixture(scope="module", params=MODES)
def robot_mode(request):
    """One robot per mode for this module (the tests run in file order: the one that
    changes the robot comes last)."""
    mode = request.param
    ep = free_endpoint()

    def deployed():
        rows = components(ep)
        return len(rows) == 11 and all(x["state"] in ("running", "ready") for x in rows)
    with std_run("lab", mode, ep, deployed, "the robot deployed"):
        yield ep, mode
    assert leftover(ep) == []


def leftover(ep):
    """Processes still running whose command line names this endpoint."""
    return [pid for pid, _, cmd in processes() if ep.encode() in cmd]


@pytest.fixture
def robot(robot_mode):
    return robot_mode[0]


@pytest.mark.parametrize("args,message", [
    (["put", "nobody", "1"], "error: put to 'nobody' failed: no behavior 'nobody'\n"),
    (["get", "logge"], "error: get from 'logge' failed: no behavior 'logge' "
                       "(did you mean 'logger'?)\n"),
    (["remove", "nobody"], "error: no behavior or reaction 'nobody'\n"),
    (["add", "x", "lab:Nope"], "error: module 'lab' has no class 'Nope'\n"),
    (["add", "x", "lab:Logger", "--uses", "arm"],
     "error: --uses 'arm' is not of the form NAME=VALUE\n"),
    (["configure", "arm", "speed", "99"], "error: arm: speed 99 out of range 1-9\n"),
    (["configure", "arm", "gain", "2"], "error: arm: no setting 'gain' (settings: speed)\n"),
    (["configure", "wave", "gain", "2"],
     "error: wave: no setting 'gain' (settings: amplitude, freq_hz, rate_hz)\n"),
    (["configure", "ticks", "gain", "2"], "error: ticks: no setting 'gain' (settings: rate_hz)\n"),
    (["configure", "arm", "speed", "[8", "--text"],        # the text reached configure()
     "error: arm: speed '[8' out of range 1-9\n"),
    (["reaction", "gard", "enable"], "error: no reaction 'gard' (did you mean 'guard'?)\n"),
    (["add-resource", "bad", "esair_std.drivers.sim:Nope"],
     "error: module 'esair_std.drivers.sim' has no class 'Nope'\n"),
    (["remove-resource", "bench.fan"], "error: 'bench.fan' is part of 'bench': remove 'bench'\n"),
    (["inspect", "nobody"], "error: no component 'nobody'\n"),
])
def test_cli_errors_are_one_clear_line(robot, args, message):
    r = esair(*args, "-e", robot, check=False)
    assert (r.returncode, r.stderr) == (1, message)
    assert len(components(robot)) == 11


def test_text_that_starts_like_json_is_sent_with_text(robot):
    """`--text` sends DATA as it is; JSON still goes as JSON."""
    ep = robot
    assert esair("add", "inbox", "lab:Logger", "-e", ep).stdout == "inbox: running\n"
    try:
        for args, data in [(["{bad json", "--text"], "{bad json"), (['{"a": [1]}'], {"a": [1]}),
                           (["plain words"], "plain words"), (['"{quoted"'], "{quoted")]:
            r = esair("put", "inbox", *args, "-e", ep, check=False)
            assert (r.returncode, r.stdout) == (0, "delivered\n"), r.stderr
            assert json.loads(esair("get", "inbox", "-e", ep).stdout)["last"] == {
                "from": "operator", "data": data}
    finally:
        esair("remove", "inbox", "-e", ep)


NOT_JSON = "is not JSON at column 2: Expecting property name enclosed in double quotes"


@pytest.mark.parametrize("args,stdin,message", [
    (["put", "inbox", "{bad json"], None, f"DATA {NOT_JSON}; to send it as text use --text"),
    (["put", "inbox", " [1, 2"], None,
     "DATA is not JSON at column 7: Expecting ',' delimiter; to send it as text use --text"),
    (["put", "inbox", '"unended'], None,
     "DATA is not JSON at column 1: Unterminated string; to send it as text use --text"),
    (["put", "inbox", "-"], '{"a": 1}\n{"b": 2}\n', "DATA is not JSON at line 2 column 1: "
                                                   "Extra data; to send it as text use --text"),
    (["send", "arm", "{angle: 10}"], None, f"VALUE {NOT_JSON}; to send it as text use --text"),
    (["configure", "arm", "speed", "{x"], None,
     f"VALUE {NOT_JSON}; to send it as text use --text"),
    (["add", "b", "lab:Logger", "-o", "gain={x"], None,
     f"-o gain {NOT_JSON}; to give it as text, write it as a JSON string (-o 'gain=\"...\"')"),
    (["add-resource", "pen", "esair_std.drivers.sim:Recorder", "-o", "keep={x"], None,
     f"-o keep {NOT_JSON}; to give it as text, write it as a JSON string (-o 'keep=\"...\"')"),
    (["put", "inbox", "[" * 100_000], None, "DATA is JSON nested too deeply to be read"),
    (["send", "arm", '{"angle": NaN}'], None,
     "VALUE is not JSON at column 11: NaN is not a JSON number; to send it as text use --text"),
])
def test_data_that_starts_like_json_but_is_not_is_a_usage_error(args, stdin, message):
    """Checked before the command connects: nothing answers on this endpoint, and the
    error is the JSON's, not "no runtime"."""
    r = esair(*args, "-e", free_endpoint(), stdin=stdin, check=False)
    assert (r.returncode, r.stderr.splitlines()[-1]) == (2, f"Error: {message}")


def test_data_in_a_file_that_is_not_json_says_the_file_line_and_column(tmp_path):
    path = tmp_path / "pose.json"
    path.write_text('{"x": 1,\n "y": }\n')
    r = esair("put", "inbox", "--file", str(path), "-e", free_endpoint(), check=False)
    assert (r.returncode, r.stderr.splitlines()[-1]) == (
        2, f"Error: DATA in {path} is not JSON at line 2 column 7: Expecting value; to send "
           "it as text use --text")


def test_an_agents_option_that_starts_like_json_is_a_usage_error():
    r = esair("agent", "--connect", free_endpoint(), "pen", "esair_std.drivers.sim:Recorder",
              "-o", "keep=[1,", check=False)
    assert (r.returncode, r.stderr.splitlines()[-1]) == (
        2, "Error: -o keep is not JSON at column 4: Expecting value; to give it as text, "
           "write it as a JSON string (-o 'keep=\"...\"')")


def test_garbage_on_the_control_endpoint(robot):
    from esair_std.transport.bus import Bus
    bus = Bus(connect=[robot])
    try:
        key = "esair/lab/ctl/"
        replies = []
        for verb, payload in [("ls", b"\xff\xfe not json"), ("ls", b"{nope"),
                                  ("ls", b"[1, 2]"),
                              ("put", b'{"to": 5}'), ("frobnicate", b"{}"),
                              ("put", b'{"to": "logger", "timeout": "soon"}'),
                              ("add", b'{"name": "x"}'), ("reaction", b'{"name": "guard"}'),
                              ("ls", b"x" * 300_000)]:
            got = bus.session.get(key + verb, payload=payload, timeout=5.0)
            replies += [json.loads(r.ok.payload.to_bytes()) for r in got if r.ok]
        assert [r.get("error") for r in replies] == [
            "bad request: message is not UTF-8 text",
            "bad request: message is not JSON: Expecting property name enclosed in double "
            "quotes: line 1 column 2 (char 1)",
            "bad request: request is not a JSON object",
            "bad request: 'to' must be a str",
            "unknown control verb 'frobnicate'",
            "bad request: 'timeout' must be a number of seconds (0-3600)",
            "bad request: missing 'class'",
            "bad request: missing 'enabled'",
            "bad request: message of 300000 bytes is over the 262144-byte cap",
        ]
    finally:
        bus.close()
    rows = components(robot)
    assert len(rows) == 11 and all(r["state"] in ("running", "ready") for r in rows)


def test_no_runtime_is_a_clear_error():
    ep = free_endpoint()
    r = esair("ls", "-e", ep, check=False)
    assert (r.returncode, r.stderr) == (
        1, f"error: no ESAIR STD runtime answers on {ep} (is `esair std run` running?)\n")
    r = esair("ls", "-e", "localhost", check=False)     # a usage error (issue 20)
    assert (r.returncode, r.stderr.splitlines()[-1]) == (
        2, "Error: Invalid value for '-e' / '--endpoint' (env var: 'ESAIR_STD_ENDPOINT'): "
           "must be PROTOCOL/HOST:PORT such as tcp/127.0.0.1:7447, not text 'localhost'")


def test_cli_controls_a_running_robot(robot_mode):
    ep, mode = robot_mode
    rows = json.loads(esair("ls", "--json", "-e", ep).stdout)["components"]
    names = [r["name"] for r in rows]
    assert names == ["guard", "logger", "follow", "tuner", "keeper", "wave", "ticks", "arm",
                     "bench", "bench.temp", "bench.fan"]
    pids = {r["pid"] for r in rows}
    assert len(pids) == (1 if mode == "thread" else 9)     # 5 components + 4 resource entries
    wait_for(lambda: json.loads(esair("get", "logger", "-e", ep).stdout)["received"] > 0,
             what="follow putting to logger")
    assert esair("add", "spare", "lab:Logger", "-e", ep).stdout == "spare: running\n"
    assert esair("put", "spare", '{"hi": 1}', "-e", ep).stdout == "delivered\n"
    assert json.loads(esair("get", "spare", "-e", ep).stdout) == {
        "received": 1, "last": {"from": "operator", "data": {"hi": 1}}}
    assert esair("remove", "spare", "-e", ep).stdout == "spare: removed\n"
    assert esair("configure", "arm", "speed", "8", "-e", ep).stdout == "8\n"
    assert esair("reaction", "guard", "disable", "-e", ep).stdout == "guard: disabled\n"
    assert esair("reaction", "guard", "enable", "-e", ep).stdout == "guard: enabled\n"
    info = json.loads(esair("inspect", "wave", "-e", ep).stdout)
    assert info["kind"] == "sensor" and info["counters"]["reported"] > 0
    assert esair("add-resource", "spare_ticks", "esair_std.drivers.sim:Counter",
                 "--allow", "*=read", "-o", "rate_hz=5", "-e", ep).stdout == (
        "spare_ticks: sensor ready\n")
    assert esair("remove-resource", "wave", "-e", ep).stdout == (
        "wave: removed (detached: follow)\n")
    follow = [r for r in json.loads(esair("ls", "--json", "-e", ep).stdout)["components"]
              if r["name"] == "follow"]
    assert follow[0]["state"] == "running"          # detached, still running
    top = esair("top", "--count", "1", "--interval", "0.2", "-e", ep).stdout
    assert "follow" in top and "spare_ticks" in top


@pytest.mark.parametrize("mode", MODES)
def test_run_headless_prints_a_summary(mode):
    ep = free_endpoint()
    r = esair("run", "lab", "--mode", mode, "--run", "1", "-e", ep)
    lines = r.stdout.splitlines()
    assert lines[0].split() == ["NAME", "KIND", "STATE", "SAMPLES", "OVERWRITTEN", "COMMANDS",
                                "PUTS_OK", "PUTS_FAILED", "RESTARTS"]
    rows = {line.split()[0]: line.split() for line in lines[1:]}
    assert list(rows) == ["guard", "logger", "follow", "tuner", "keeper", "wave", "ticks",
                          "arm", "bench.temp", "bench.fan"]
    assert rows["wave"][2] == "ready" and int(rows["wave"][3]) > 0
    assert rows["follow"][2] == "running" and int(rows["follow"][3]) > 0
    assert int(rows["arm"][5]) > 0                       # commands the actuator carried out
    assert (f"robot 'lab' running in {mode} mode, control endpoint {ep} (10 components)"
            in r.stderr.splitlines())
    assert leftover(ep) == []


def test_agents_leave_when_the_runtime_is_killed():
    ep = free_endpoint()
    proc = subprocess.Popen([sys.executable, "-m", "esair_min.cli", "std", "run", "lab",
                             "--mode", "process", "-e", ep], cwd=HERE,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        # every component running
        wait_for(lambda: lab_started(ep), timeout=60, what="every component running")
        assert len(leftover(ep)) >= 10
    finally:
        proc.kill()
        proc.wait(10)
    wait_for(lambda: leftover(ep) == [], timeout=30, what="every agent gone")


def test_run_refuses_bad_input_with_one_line(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text('robot: lab\nbehaviors:\n  x: {class: "nomod:X"}\n')
    r = esair("run", str(bad), "--run", "1", "-e", free_endpoint(), check=False)
    assert (r.returncode, r.stderr) == (
        1, f"error: {bad}:3:14: no module named 'nomod'; looked in the deployment's folder, "
           "then sys.path\n")
    # refused before anything is read or started: in this process (no interpreter start)
    r = std_cli("run", "nosuch", "--run", "1")
    assert (r.returncode, r.stderr) == (
        1, "error: nosuch: no such file, and no bundled example named 'nosuch' "
           "(bundled: lab, papaman, starfish)\n")
    r = std_cli("run", "lab", "--run", "1", "-e", "tcp/127.0.0.1")
    assert (r.returncode, r.stderr.splitlines()[-1]) == (      # a usage error (issue 20)
        2, "Error: Invalid value for '-e' / '--endpoint' (env var: 'ESAIR_STD_ENDPOINT'): "
           "needs a host and a port: PROTOCOL/HOST:PORT such as tcp/127.0.0.1:7447, not text "
           "'tcp/127.0.0.1'")


def test_the_put_samples_answer_or_count_garbage(robot_mode):
    """A component process's put travels as samples (transport/calls.py): a good one is
    answered on the sender's own answer key, a bad one with its error, garbage without an
    id is counted where ``esair std inspect runtime`` shows it; nothing else changes."""
    import queue

    import zenoh

    from esair_std.transport.bus import Bus
    ep, _mode = robot_mode
    bus = Bus(connect=[ep])
    answers: queue.Queue = queue.Queue()
    try:
        before = json.loads(esair("inspect", "runtime", "-e", ep).stdout)["counters"]
        bus.subscribe("esair/lab/bs/tester/answer", answers.put)
        # the subscription must reach the runtime first (an answer to nobody is lost):
        # ask until one answer comes (id 0: a put to nobody, answered at once)
        hello = json.dumps({"id": 0, "to": "nobody", "data": 0, "timeout": 0}).encode()
        def handshake() -> None:
            deadline = time.monotonic() + 30
            while answers.empty() and time.monotonic() < deadline:
                bus.session.put("esair/lab/ctl/put/tester", hello)
                with contextlib.suppress(queue.Empty):
                    answers.put(answers.get(timeout=0.2))
            assert not answers.empty(), "no answer to the handshake within 30 s"
        handshake()

        def next_answer(timeout: float) -> dict:          # late handshake answers skipped
            while (a := answers.get(timeout=timeout))["id"] == 0:
                pass
            return a
        for payload in [b"\xff not json", b"[1]", b'{"to": "logger"}', b'{"id": "7"}',
                        b'{"id": true, "to": "logger"}', b"x" * 300_000]:
            # BLOCK: with Zenoh's default (DROP) a busy machine dropped one of them
            bus.session.put("esair/lab/ctl/put/tester", payload,
                            congestion_control=zenoh.CongestionControl.BLOCK)
        for key in ("esair/lab/bs/logger/result", "esair/lab/bs/logger/answer"):
            bus.session.put(key, b'{"id": 1, "r": "delivered"}')
        logger_before = json.loads(esair("inspect", "logger", "-e", ep).stdout)["counters"]
        # a behavior's reports of its room, and deliveries into it (modes/process.py):
        # garbage, a report of another generation, a delivery with no sender
        for key, payload in [("esair/lab/bs/logger/credit", b"\xff"),
                             ("esair/lab/bs/logger/credit", b'{"gen": 99, "room": 9999, "open": true}'),
                             ("esair/lab/bs/logger/credit", b'{"gen": 1, "room": "all"}'),
                             ("esair/lab/bs/nobody/credit", b'{"gen": 1, "room": 9999, "open": true}'),
                             ("esair/lab/bs/logger/deliver", b"[1, 2]"),
                             ("esair/lab/bs/logger/deliver", b'{"data": 1}'),
                             ("esair/lab/bs/logger/deliver", b"x" * 300_000)]:
            bus.session.put(key, payload, congestion_control=zenoh.CongestionControl.BLOCK)
        # the answers wait for a congested link (transport/calls.py): the
        # 300 KB payloads above must have gone through first, or a loaded machine drops
        # answers behind them. One more handshake says so.
        while not answers.empty():                      # none but the handshake's
            assert answers.get_nowait()["id"] == 0
        handshake()
        for body in [{"id": 1, "to": "logger", "data": {"n": 1}, "timeout": 1.0},
                     {"id": 2, "to": 5},
                     {"id": 3, "to": "nobody", "data": 1, "timeout": 0.2},
                     {"id": 4, "to": "logger", "data": 1, "timeout": "soon"}]:
            bus.session.put("esair/lab/ctl/put/tester", json.dumps(body).encode(),
                            congestion_control=zenoh.CongestionControl.BLOCK)
        got = []
        with contextlib.suppress(queue.Empty):
            while len(got) < 4:
                got.append(next_answer(30))
        if len(got) < 4:                                 # say what came and what counted
            counters = json.loads(esair("inspect", "runtime", "-e", ep).stdout)["counters"]
            pytest.fail(f"answers {got}; runtime counters before {before}, now {counters}")
        got.sort(key=lambda a: a["id"])
        assert got == [
            {"id": 1, "ok": {"delivered": True, "reason": ""}},
            {"id": 2, "error": "bad request: 'to' must be a str", "type": "ControlError"},
            {"id": 3, "ok": {"delivered": False, "reason": "no behavior 'nobody'"}},
            {"id": 4, "error": "bad request: 'timeout' must be a number of seconds (0-3600)",
             "type": "ControlError"},
        ]
        after = json.loads(esair("inspect", "runtime", "-e", ep).stdout)["counters"]
        assert (after["put_samples"]["bad_requests"]
                - before["put_samples"]["bad_requests"]) == 6    # 3 not JSON/object, 3 ids
        assert after["put_samples"]["requests"] - before["put_samples"]["requests"] >= 4
        with pytest.raises(queue.Empty):
            next_answer(0.01)
        logger = json.loads(esair("inspect", "logger", "-e", ep).stdout)["counters"]
        if _mode == "process":
            assert (after["credit_reports"]["bad_reports"]
                    - before["credit_reports"]["bad_reports"]) == 4
            assert (logger["deliver_samples"]["bad"]
                    - logger_before["deliver_samples"]["bad"]) == 3
        else:                        # thread mode listens on none of these keys
            assert "credit_reports" not in after and "deliver_samples" not in logger
        assert logger["reserved_refused"] == logger_before["reserved_refused"] == 0
    finally:
        bus.close()
    rows = json.loads(esair("ls", "--json", "-e", ep).stdout)["components"]
    assert len(rows) == 11 and all(r["state"] in ("running", "ready") for r in rows)
