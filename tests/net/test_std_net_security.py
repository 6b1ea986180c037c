"""Nobody gets in where they don't belong (issue 12 item 3), against a real control
center with a TLS (mTLS) endpoint and access control, from another network namespace:
checked at the Zenoh layer (no session, or the ACL drops it) AND at the RS (join with a
proof of identity, registration against `allow`), so a gap in one is caught by the
other. Garbage and oversized messages on every key the runtime and its agents listen on
are refused without a crash."""

from __future__ import annotations

import subprocess

import pytest

from esair_std.transport.tls_certs import make_certs
from esair_std.transport.security_config import SecuritySpec, session_inserts
from tests.support.netns import make_net, wait_for
from bench.toolkit.netstd import Center, agent
from bench.toolkit.zpeer import Peer

SECURE = """
robot: lab
mode: process
endpoint: ENDPOINT
security:
  ca: pki/ca.pem
  cert: pki/server.pem
  key: pki/server.key
  lease_ms: 1000
  agents:
    pusher: {cn: pusher}
    reader: {cn: reader}
    intruder: {cn: intruder}    # let through the ACL to ctl on purpose: the RS must stop it
    putter: {cn: putter}
resources:
  arm: {class: "bench.toolkit.netcomps:Wheel", allow: {pusher: command, reader: read}}
  mic: {class: "bench.toolkit.netcomps:Counter", rate: 50, allow: {pusher: read, reader: read}}
behaviors:
  idle: {class: "bench.toolkit.netcomps:Idle"}
  sink: {class: "bench.toolkit.netcomps:Sink"}
"""
ARM, MIC = "esair/lab/actuator/arm", "esair/lab/sensor/mic"


@pytest.fixture(scope="module")
def secure(tmp_path_factory):
    """One control center with a TLS endpoint for the module (its start is the slow part)."""
    folder = tmp_path_factory.mktemp("secure")
    net = make_net(2)
    try:
        make_certs(folder / "pki", clients=["pusher", "reader", "intruder", "stranger", "putter"],
                   hosts=[net[0].addr])
        make_certs(folder / "other", clients=["pusher"], hosts=[net[0].addr])
        center = Center(net[0], folder, SECURE, tls=True)
        center.pki = folder / "pki"
        center.folder = folder
        yield net, center
    finally:
        net.close()


def _creds(center, who: str, pki: str = "pki") -> list[str]:
    """Certificate options; --robot: with access control on, a wildcard ping is denied."""
    d = center.folder / pki
    return ["--robot", "lab", "--ca", str(center.pki / "ca.pem"),
            "--cert", str(d / f"{who}.pem"), "--key", str(d / f"{who}.key")]


def _raw(net, center, who: str) -> Peer:
    """A raw Zenoh client with `who`'s (valid) certificate: past TLS, subject to the ACL."""
    d = center.pki
    sec = SecuritySpec(ca=d / "ca.pem", cert=d / f"{who}.pem", key=d / f"{who}.key")
    peer = Peer(net[1], {"mode": "client", "scouting/multicast/enabled": False,
                         "connect/endpoints": [center.endpoint], "listen/endpoints": [],
                         **session_inserts(sec, ".", listen=False)})
    assert peer.error is None, peer.error
    return peer


def _ctl(center, *args):
    """esair std ... on the control center's computer, over its loopback listener
    (the TLS endpoint wants certificates; local processes are trusted)."""
    return center.ctl(*args, endpoint=center.local)


@pytest.fixture(scope="module")
def local(secure):
    center = secure[1]
    assert center.local.startswith("tcp/127.0.0.1:")
    return center


def test_no_certificate_or_a_wrong_one_gets_no_session(secure):
    """An agent with no certificate and one with a certificate of another CA, at once
    (each tries for the agent's connect window before it gives up)."""
    net, center = secure
    procs = {}
    for who, pki in [(None, None), ("pusher", "other")]:
        creds = ["--ca", str(center.pki / "ca.pem")] + (_creds(center, who, pki)[4:] if who else [])
        procs[who, pki] = agent(net[1], center.endpoint, "pusher", "bench.toolkit.netcomps:Pusher",
                                "--uses", "arm=command", *creds)
    for case, proc in procs.items():
        assert proc.wait_exit(60) == 1, (case, proc.output())
        assert proc.lines[-1].startswith(
            f"error: cannot reach the control center at {center.endpoint}: "), (case, proc.output())


def test_acl_stops_a_valid_certificate_that_is_no_agent_of_the_robot(secure, local):
    net, center = secure
    stranger = _raw(net, center, "stranger")
    assert stranger.get("esair/lab/ctl/ping", 1.0) == []           # cannot ask anything
    assert stranger.cmd(f"getx {ARM} nulls")["replies"] == []       # nor command the arm
    stranger.cmd(f"sub {MIC}")
    reader = _raw(net, center, "reader")                            # an agent that may read
    reader.cmd(f"sub {MIC}")
    assert reader.wait_event(lambda e: e.get("sample") == MIC, 10)
    assert stranger.samples(MIC) == []                              # nor read the sensor
    assert reader.cmd(f"getx {ARM} nulls")["replies"] == []         # read grant: no command
    stranger.close()
    reader.close()


def test_rs_refuses_a_join_under_someone_elses_name(secure, local):
    """`intruder` is an agent of the robot, so the ACL lets it ask ctl/join; it claims
    to be `pusher` with its own certificate: the RS's identity check refuses it."""
    net, center = secure
    proc = agent(net[1], center.endpoint, "pusher", "bench.toolkit.netcomps:Pusher", "--uses", "arm=command",
                 *_creds(center, "intruder"))
    assert proc.wait_exit(60) == 1
    assert proc.lines[-1] == ("error: join refused: pusher: certificate is not "
                              "'pusher''s"), proc.output()
    assert "pusher" not in {r["name"] for r in __import__("json").loads(
        _ctl(center, "ls", "--json"))["components"]}


def test_a_registered_agent_works_and_a_read_behavior_cannot_command(secure, local):
    net, center = secure
    pusher = agent(net[1], center.endpoint, "pusher", "bench.toolkit.netcomps:Pusher",
                   "--uses", "arm=command", *_creds(center, "pusher"))
    reader = agent(net[1], center.endpoint, "reader", "bench.toolkit.netcomps:Pusher", "--uses", "arm=read",
                   *_creds(center, "reader"))
    import json
    get = lambda name: json.loads(_ctl(center, "get", name, "--timeout", "2"))  # noqa: E731

    def running():
        assert pusher.proc.poll() is None and reader.proc.poll() is None, (
            pusher.output() + reader.output())
        rows = {r["name"]: r["state"] for r in json.loads(_ctl(center, "ls", "--json"))["components"]}
        return rows.get("pusher") == rows.get("reader") == "running"
    wait_for(running, 30, what="pusher and reader running")
    wait_for(lambda: (get("pusher")["last"] or {}).get("n", 0) >= 2, 30, what="pusher's commands")
    wait_for(lambda: get("reader")["errors"], 30, what="reader's refusal")
    assert get("reader")["errors"] == ["behavior 'reader' lists 'arm' for read in its uses, "
                                       "not command"]
    assert get("reader")["sent"] == 0
    arm = json.loads(_ctl(center, "inspect", "arm"))
    assert arm["grants"] == {"pusher": "command"} and arm["refused"] >= 1
    rows = {r["name"]: r for r in json.loads(_ctl(center, "ls", "--json"))["components"]}
    assert rows["pusher"]["host"] == f"pc-{net[1].addr}"
    pusher.proc.terminate()
    reader.proc.terminate()
    assert pusher.wait_exit(30) == 0 and reader.wait_exit(30) == 0


LOGINS = """
robot: lab
mode: process
endpoint: ENDPOINT
security:
  users: users.txt
  agents:
    pusher: {user: pusher}
  operators:
    op: {user: op}
resources:
  arm: {class: "bench.toolkit.netcomps:Wheel", allow: {pusher: command, operator: command}}
behaviors:
  idle: {class: "bench.toolkit.netcomps:Idle"}
"""


def _login(user: str, password: str) -> dict:
    return {"transport/auth/usrpwd/user": user, "transport/auth/usrpwd/password": password}


@pytest.fixture(scope="module")
def _logins(tmp_path_factory):
    import json

    folder = tmp_path_factory.mktemp("logins")
    (folder / "users.txt").write_text("pusher:s3cret\nop:op-pw\nnobody:no-pw\n")
    (folder / "good").write_text("s3cret\n")
    (folder / "bad").write_text("guess\n")
    with make_net(2) as net:
        # the operator's own login for the `esair std` commands center.ctl runs on the
        # control center's computer (the control CLI reads it from ESAIR_STD_SESSION)
        center = Center(net[0], folder, LOGINS, session=json.dumps(_login("op", "op-pw")))
        center.folder = folder
        yield net, center


@pytest.fixture
def logins(_logins):
    """A control center whose peers log in (security.users), with agents' and an
    operator's logins; shared by the tests, each ending the agents it started."""
    net = _logins[0]
    before = {id(p) for p in net[1].procs}
    yield _logins
    for proc in net[1].procs:
        if id(proc) not in before and proc.poll() is None:
            proc.kill()
            proc.wait(10)


def test_user_password_logins_with_the_runtime(logins):
    """Logins instead of certificates: a good one joins (its proof an HMAC of the
    password) and commands the arm; a wrong password gets no session at all."""
    import json

    net, center = logins
    login = ["--robot", "lab", "--user", "pusher", "--password-file"]
    # both at once: the wrong one never gets a session, so it never joins
    wrong = agent(net[1], center.endpoint, "pusher", "bench.toolkit.netcomps:Pusher",
                  "--uses", "arm=command", *login, str(center.folder / "bad"))
    good = agent(net[1], center.endpoint, "pusher", "bench.toolkit.netcomps:Pusher",
                 "--uses", "arm=command", *login, str(center.folder / "good"))
    assert wrong.wait_exit(60) == 1
    assert wrong.lines[-1].startswith(
        f"error: cannot reach the control center at {center.endpoint}: "), wrong.output()

    def pushed():
        assert good.proc.poll() is None, good.output()
        out = center.ctl("get", "pusher", "--timeout", "2", endpoint=center.local,
                         check=False)
        return not out.startswith("error") and (json.loads(out)["last"] or {}).get("n", 0)
    wait_for(pushed, 30, what="pusher's commands through a login")


def test_an_operators_login_works_on_the_main_endpoint_for_the_control_verbs_only(logins):
    """security.operators: an operator's login gets the control verbs on the main
    endpoint, from another computer; it cannot speak an agent's verb, read a sensor or
    command an actuator by itself, and a login that is no operator's gets nothing."""
    import json

    from bench.toolkit.netstd import cli

    net, center = logins
    login = _login

    def esair(who: dict, *args: str) -> subprocess.Popen:
        return net[1].popen("env", f"ESAIR_STD_SESSION={json.dumps(who)}",
                            *cli(*args, "-e", center.endpoint, "-r", "lab"),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)

    def done(proc: subprocess.Popen) -> subprocess.CompletedProcess:
        out, err = proc.communicate(timeout=60)
        return subprocess.CompletedProcess(proc.args, proc.returncode, out, err)

    # the three commands at once (each its own interpreter; the one no operator's
    # login waits out the command line's timeout)
    ls, sent, other = map(done, [esair(login("op", "op-pw"), "ls", "--json"),
                                 esair(login("op", "op-pw"), "send", "arm", "7"),
                                 esair(login("nobody", "no-pw"), "ls")])
    assert ls.returncode == 0, ls.stderr
    assert {r["name"] for r in json.loads(ls.stdout)["components"]} >= {"idle", "arm"}
    assert sent.returncode == 0, sent.stderr
    assert other.returncode == 1
    assert other.stderr.strip() == (f"error: the runtime of robot 'lab' on {center.endpoint} "
                                    "did not answer 'ls'")
    raw = Peer(net[1], {"mode": "client", "scouting/multicast/enabled": False,
                        "connect/endpoints": [center.endpoint], "listen/endpoints": [],
                        **login("op", "op-pw")})
    try:
        assert raw.error is None, raw.error
        assert raw.get("esair/lab/ctl/ping", 2.0, "{}") != []          # a control verb
        # an agent's verb, a behavior's key, an actuator: denied (no answer at all)
        assert raw.get("esair/lab/ctl/report", 1.0, "{}") == []
        assert raw.get("esair/lab/bs/idle", 1.0, "{}") == []
        assert raw.get("esair/lab/actuator/arm", 1.0, "{}") == []
    finally:
        raw.close()


def test_a_remote_behavior_puts_through_the_bs_and_nobody_puts_in_its_name(secure, local):
    """A put travels as samples on keys that name the sender (transport/calls.py): the
    ACL lets a remote agent use only its own, so nobody puts in another's name."""
    import json
    net, center = secure
    putter = agent(net[1], center.endpoint, "putter", "bench.toolkit.netcomps:PutBench", "-o", "n=200",
                   *_creds(center, "putter"))
    get = lambda name: json.loads(_ctl(center, "get", name, "--timeout", "2"))  # noqa: E731
    def finished():              # no behavior 'putter' until it joins; None until done
        out = center.ctl("get", "putter", "--timeout", "2", check=False,
                         endpoint=center.local)
        return None if out.startswith("error") else json.loads(out)
    done = wait_for(finished, 60, what="putter's 200 puts")
    assert (done["failed"], len(done["times"])) == (0, 200), putter.output()
    assert get("sink") == {"putter": 200}
    forger = _raw(net, center, "pusher")     # an agent of the robot, not the putter
    answer = "esair/lab/bs/pusher/answer"
    forger.cmd(f"sub {answer}")
    for key in ("esair/lab/ctl/put/putter", "esair/lab/ctl/put/idle"):      # not its keys
        forger.cmd(f'put {key} {{"id":1,"to":"sink","data":"forged"}}')
    stranger = _raw(net, center, "stranger")                                # no agent
    stranger.cmd('put esair/lab/ctl/put/stranger {"id":1,"to":"sink","data":"x"}')
    forger.cmd('put esair/lab/ctl/put/pusher {"id":2,"to":"sink","data":"mine"}')
    ev = forger.wait_event(lambda e: e.get("sample") == answer, 20)         # after the forgeries
    assert json.loads(ev["payload"]) == {"ok": {"delivered": True, "reason": ""}, "id": 2}
    assert get("sink") == {"putter": 200, "pusher": 1}
    forger.close()
    stranger.close()
    putter.proc.terminate()
    assert putter.wait_exit(30) == 0
