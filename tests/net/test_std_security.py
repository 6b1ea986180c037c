"""Security of the control endpoint at the Zenoh layer, between two network namespaces:
mTLS, user/password and access control as esair_std.transport.security_config configures them,
checked with raw Zenoh sessions (the runtime's own checks are tested on top of these).

The control center (host 0) is a Zenoh router listening on the control endpoint, with a
queryable on ctl/**, a subscriber on actuator/** and a sensor it publishes; an agent
(host 1) is a Zenoh client that tries to query ctl, publish to the actuator's key and
read the sensor's stream."""

import pytest
from pydantic import ValidationError

from esair_std.errors import TransportError
from esair_std.transport.tls_certs import CertError, common_name, make_certs
from esair_std.transport.security_config import Security, access_control, session_inserts

from tests.support.std import wait_for
from bench.toolkit.zpeer import Peer

ROBOT = "lab"
CTL, ACT, SENSOR = "esair/lab/ctl/ls", "esair/lab/actuator/knee", "esair/lab/sensor/feet"


@pytest.fixture(scope="module")
def pki(tmp_path_factory):
    d = tmp_path_factory.mktemp("pki")
    make_certs(d / "good", clients=["locate", "intruder"], hosts=["10.77.0.1"])
    make_certs(d / "other", clients=["locate"], hosts=["10.77.0.1"])      # another CA
    (d / "users.txt").write_text("locate:s3cret\nintruder:pw\n")
    (d / "pw-good").write_text("s3cret\n")
    (d / "pw-bad").write_text("guess\n")
    return d


def _center(host, sec: Security, base, endpoint: str, grants=None) -> Peer:
    conf = {"mode": "router", "scouting/multicast/enabled": False,
            "listen/endpoints": [endpoint], "connect/endpoints": [],
            **session_inserts(sec, base, listen=True)}
    acl = access_control(sec, ROBOT, grants)
    if acl:
        conf["access_control"] = acl
    center = Peer(host, conf)
    center.cmd("serve esair/lab/ctl/**")
    center.cmd(f"sub {ACT}")
    return center


def _agent(host, sec: Security | None, base, endpoint: str) -> Peer:
    conf = {"mode": "client", "scouting/multicast/enabled": False,
            "connect/endpoints": [endpoint], "listen/endpoints": [],
            "connect/exit_on_failure": False, "connect/timeout_ms": 0,
            **session_inserts(sec, base, listen=False)}
    return Peer(host, conf)


def _reach(center: Peer, agent: Peer) -> dict:
    """What the agent can do: query ctl, command the actuator, read the sensor."""
    if agent.error:                        # a client that cannot connect cannot open at all
        assert agent.error.startswith("Unable to connect to any of"), agent.error
        return NONE
    out = {"ctl": agent.get(CTL, 2.0) == ["pong:hi"]}
    agent.cmd(f"sub {SENSOR}")
    agent.cmd(f"put {ACT} go")
    out["actuator"] = center.wait_event(lambda e: e.get("sample") == ACT, 1.5) is not None
    center.cmd(f"put {SENSOR} 42")
    out["sensor"] = agent.wait_event(lambda e: e.get("sample") == SENSOR, 1.5) is not None
    return out


ALL = {"ctl": True, "actuator": True, "sensor": True}
NONE = {"ctl": False, "actuator": False, "sensor": False}


def _tls(pki, who: str, ca: str = "good", **kw) -> Security:
    return Security(ca=pki / "good" / "ca.pem", cert=pki / ca / f"{who}.pem",
                    key=pki / ca / f"{who}.key", **kw)


@pytest.mark.parametrize("who, expect", [
    ("locate", ALL),                 # certificate signed by the robot's CA
    ("none", NONE),                  # no client certificate at all
    ("other", NONE),                 # certificate from another CA
])
def test_mtls_endpoint_lets_in_only_certificates_of_its_ca(net, pki, who, expect):
    endpoint = "tls/10.77.0.1:7447"
    center = _center(net[0], _tls(pki, "server"), pki, endpoint)
    if who == "none":
        sec = Security(ca=pki / "good" / "ca.pem", mtls=False)
    else:
        sec = _tls(pki, "locate", ca="good" if who == "locate" else "other")
    assert _reach(center, _agent(net[1], sec, pki, endpoint)) == expect


@pytest.mark.parametrize("login, expect", [
    ("pw-good", ALL), ("pw-bad", NONE), (None, NONE)])
def test_user_password_endpoint_lets_in_only_known_logins(net, pki, login, expect):
    endpoint = "tcp/10.77.0.1:7447"
    center = _center(net[0], Security(users=pki / "users.txt"), pki, endpoint)
    sec = Security(user="locate", password_file=pki / login) if login else None
    assert _reach(center, _agent(net[1], sec, pki, endpoint)) == expect


def test_acl_lets_an_agent_touch_only_the_keys_of_its_grants(net, pki):
    """Valid certificates both; `intruder` is no agent of the deployment, `locate` reads
    feet but commands nothing: the ACL stops what the link layer lets through."""
    endpoint = "tls/10.77.0.1:7447"
    sec = _tls(pki, "server", agents={"locate": {"cn": "locate"}})
    center = _center(net[0], sec, pki, endpoint, grants={"locate": {"reads": ["feet"]}})
    intruder = _agent(net[1], _tls(pki, "intruder"), pki, endpoint)
    assert intruder.error is None                  # the link layer lets it in...
    assert _reach(center, intruder) == NONE
    intruder.close()
    locate = _agent(net[1], _tls(pki, "locate"), pki, endpoint)
    assert _reach(center, locate) == {"ctl": True, "actuator": False, "sensor": True}
    # the runtime's change notices reach an agent (a remote HMI asks ls when told)
    changed = f"esair/{ROBOT}/changed"
    locate.cmd(f"sub {changed}")

    def heard() -> bool:         # put again until the subscription has reached the center
        center.cmd(f"put {changed} 1")
        return locate.wait_event(lambda e: e.get("sample") == changed, 0.5) is not None
    wait_for(heard, timeout=20, what="the change notice at the agent")


def test_acl_command_grant_opens_the_actuator_key(net, pki):
    endpoint = "tcp/10.77.0.1:7447"
    sec = Security(users=pki / "users.txt", agents={"locate": {"user": "locate"}})
    center = _center(net[0], sec, pki, endpoint,
                     grants={"locate": {"commands": ["knee"]}})
    agent = _agent(net[1], Security(user="locate", password_file=pki / "pw-good"), pki, endpoint)
    # a put on a command key is no query: only queries (send with a reply) are granted
    assert _reach(center, agent) == {"ctl": True, "actuator": False, "sensor": False}
    center.cmd(f"serve {ACT}")
    assert agent.get(ACT, 2.0) == ["pong:hi"]


def test_acl_lets_a_resource_host_publish_command_records_of_its_own_entry_only(net, pki):
    """A host of the entry `locate` (provides) publishes its command records on
    commands/locate (transport/records.py); a batch on another entry's key is stopped,
    so it cannot speak for another host's actuators. Order tells: the stopped put went
    first, the one after it arrived alone."""
    endpoint = "tcp/10.77.0.1:7447"
    sec = Security(users=pki / "users.txt", agents={"locate": {"user": "locate"}})
    center = _center(net[0], sec, pki, endpoint,
                     grants={"locate": {"provides": ["locate", "locate.$*"]}})
    own, other = f"esair/{ROBOT}/commands/locate", f"esair/{ROBOT}/commands/knee"
    center.cmd(f"sub esair/{ROBOT}/commands/*")
    agent = _agent(net[1], Security(user="locate", password_file=pki / "pw-good"), pki, endpoint)

    def heard() -> bool:         # put again until the subscription has reached the agent
        agent.cmd(f"put {own} 1")
        return center.wait_event(lambda e: e.get("sample") == own, 0.5) is not None
    wait_for(heard, timeout=20, what="the agent's own records at the center")
    n = len(center.samples(own))
    agent.cmd(f"put {other} forged")
    agent.cmd(f"put {own} after")
    wait_for(lambda: len(center.samples(own)) > n, timeout=10, what="the put after the forged one")
    assert center.samples(other) == []


# --- the pieces, without a network ---------------------------------------------------

def test_certs_have_the_names_acl_matches(tmp_path):
    made = make_certs(tmp_path, clients=["locate"], hosts=["10.77.0.1"])
    assert sorted(made) == ["ca", "locate", "server"]
    assert common_name(made["locate"]) == "locate"
    assert oct((tmp_path / "locate.key").stat().st_mode & 0o777) == "0o600"


@pytest.mark.parametrize("name", ["ca", "server", "bad name", "-x"])
def test_certs_refuse_bad_client_names(tmp_path, name):
    with pytest.raises(CertError) as exc:
        make_certs(tmp_path, clients=[name])
    assert str(exc.value) == (f"bad client name {name!r}: letters, digits, '_', '.', '-' "
                              "(and not 'ca' or 'server')")


@pytest.mark.parametrize("section, message", [
    ({"cert": "a.pem"}, "'cert' and 'key' go together"),
    ({"cert": "a.pem", "key": "a.key"},
     "mtls needs 'ca' (the authority that signed the peers' certificates)"),
    ({"user": "locate"}, "'user' and 'password_file' go together"),
    ({"agents": {"locate": {}}}, "give exactly one of 'cn' (certificate common name) or 'user'"),
    ({"operators": {"Op": {"user": "op"}}},
     "operator name 'Op' is not a name ([a-z][a-z0-9_]*, at most 32 characters)"),
    ({"operators": {"op": {"user": "op", "cn": "op"}}},
     "give exactly one of 'cn' (certificate common name) or 'user'"),
])
def test_security_section_errors(section, message):
    with pytest.raises(ValidationError) as exc:
        Security.model_validate(section)
    assert message in str(exc.value)


def test_missing_files_are_named(tmp_path):
    with pytest.raises(TransportError) as exc:
        session_inserts(Security(ca="ca.pem", cert="s.pem", key="s.key"), tmp_path, listen=True)
    assert str(exc.value) == f"security: ca {tmp_path / 'ca.pem'}: no such file"
    (tmp_path / "users.txt").write_text("alice\n")
    with pytest.raises(TransportError) as exc:
        session_inserts(Security(users="users.txt"), tmp_path, listen=True)
    assert str(exc.value) == f"security: users {tmp_path / 'users.txt'}:1: expected 'name:password'"


def test_no_agents_no_acl_and_local_peers_trusted():
    assert access_control(None, ROBOT) is None
    assert access_control(Security(), ROBOT) is None
    acl = access_control(Security(agents={"a": {"cn": "a"}}), ROBOT)
    assert acl["default_permission"] == "deny"
    assert {"id": "local", "interfaces": ["lo"]} in acl["subjects"]
    assert {"id": "agent.a", "cert_common_names": ["a"]} in acl["subjects"]


def test_operators_alone_turn_the_acl_on_with_the_control_verbs_only():
    acl = access_control(Security(operators={"op": {"user": "op"}}), ROBOT)
    assert acl["default_permission"] == "deny"
    assert {"id": "operator.op", "usernames": ["op"]} in acl["subjects"]
    mine = [r for r in acl["rules"] if r["id"].startswith("operator.op.")]
    asked = {k.rsplit("/", 1)[1] for r in mine if "query" in r["messages"] for k in r["key_exprs"]}
    assert "ls" in asked and "send" in asked
    assert not asked & {"register", "attach", "report", "resstate", "resinfo", "hello", "join"}
    assert all(k.startswith(f"esair/{ROBOT}/ctl/") for r in mine for k in r["key_exprs"])


def test_the_deployment_file_carries_the_section(tmp_path):
    from esair_std.deploy import DeployError, load_deployment

    path = tmp_path / "lab.yaml"
    path.write_text("robot: lab\nendpoint: tls/10.77.0.1:7447\nsecurity:\n"
                    "  ca: ca.pem\n  cert: server.pem\n  key: server.key\n"
                    "  agents:\n    locate: {cn: locate}\n")
    dep = load_deployment(path)
    assert dep.security.agents["locate"].cn == "locate" and dep.security.lease_ms == 2000
    path.write_text("robot: lab\nsecurity:\n  ca: ca.pem\n  cert: server.pem\n  agent: {}\n")
    with pytest.raises(DeployError) as exc:
        load_deployment(path)
    assert str(exc.value) == f"{path}:5:3: unknown key 'agent' (did you mean 'agents'?)"
    path.write_text("robot: lab\nsecurity:\n  agents:\n    Locate: {cn: x}\n")
    with pytest.raises(DeployError) as exc:
        load_deployment(path)
    assert str(exc.value).endswith("agent name 'Locate' is not a component name "
                                   "([a-z][a-z0-9_]*, at most 32 characters)")
