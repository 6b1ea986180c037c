"""The deployment's ``security:`` section and the Zenoh configuration it becomes.

Two layers keep strangers out of a robot (docs/std-network.md, "Security"):

* the **link**: the control endpoint is ``tls/HOST:PORT`` with client certificates
  (mTLS: a peer without a certificate signed by ``ca`` never gets a session), and/or
  Zenoh user/password authentication (``users``: a ``name:password`` file; a peer
  without a valid login never gets a session);
* **access control** (Zenoh ACL, default deny): each remote agent, known by its
  certificate's common name or its user name, may touch only the keys its role needs
  (:func:`acl_rules`); the runtime's own component processes on this computer come in
  over the loopback interface and are allowed everything (``local: true``).

The RS/AC checks (registration against the deployment's ``allow``) stay on top of both.

Zenoh 1.10 keys used (checked against real sessions in tests/net/test_std_security.py):
``transport/link/tls/{root_ca_certificate, listen_certificate, listen_private_key,
connect_certificate, connect_private_key, enable_mtls, verify_name_on_connect}`` —
``enable_mtls`` must be true on BOTH sides, else the connecting side sends no
certificate; ``transport/auth/usrpwd/{user, password, dictionary_file}``;
``transport/link/tx/lease`` (ms; a silent peer is dropped after it); ``access_control``
(``enabled, default_permission, rules, subjects, policies``; subjects by
``cert_common_names``, ``usernames``, ``interfaces``).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Sequence

from .codec import JSONObject

if TYPE_CHECKING:
    from ..deploy.security import AgentIdentity, SecuritySpec as Security

from ..errors import TransportError

ALL_MESSAGES = ["put", "delete", "declare_subscriber", "query", "reply", "declare_queryable",
                "liveliness_token", "liveliness_query", "declare_liveliness_subscriber"]
LOOPBACK = "lo"


def __getattr__(name: str) -> type[Security]:
    """``SecuritySpec`` / ``Security`` (the deployment's section, as the transport calls
    it), imported on first use: it is a pydantic model, and an agent process that only
    reads a validated section's fields (any object with them) need not load pydantic."""
    if name in ("SecuritySpec", "Security"):
        from ..deploy.security import SecuritySpec
        return SecuritySpec
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

LEASE_MS = 2000          # default link lease of every STD session (zenoh's own: 10 s)
RETRY = {"period_init_ms": 100, "period_max_ms": 250, "period_increase_factor": 1.5}


def link_inserts(lease_ms: int = LEASE_MS) -> JSONObject:
    """Zenoh config entries every STD session should have, with or without security:
    a short link lease (a silent computer is dropped, and its liveliness tokens gone,
    after ``lease_ms``; zenoh sends 4 keep-alives per lease) and fast reconnection
    (a client retries its endpoint every 100-250 ms, so a healed link carries data again
    within a fraction of a second; with zenoh's default 1-4 s back-off it took 3.8 s)."""
    return {"transport/link/tx/lease": lease_ms, "connect/retry": dict(RETRY)}


def _file(base: Path, path: Path | None, what: str) -> str | None:
    if path is None:
        return None
    full = path if path.is_absolute() else base / path
    if not full.is_file():
        raise TransportError(f"security: {what} {full}: no such file")
    return str(full)


def _password(base: Path, sec: Security) -> str | None:
    path = _file(base, sec.password_file, "password_file")
    if path is None:
        return None
    text = Path(path).read_text().strip()
    if not text or "\n" in text:
        raise TransportError(f"security: password_file {path}: must hold one line, the password")
    return text


def session_inserts(sec: Security | None, base_dir: str | Path = ".", *,
                    listen: bool) -> JSONObject:
    """The zenoh config entries (``Config.insert_json5`` path -> value) for ``sec``.

    ``listen``: this session accepts peers (control center) rather than only connecting.
    Without ``sec`` only the lease default applies. The ACL is not included: see
    :func:`access_control` (it needs the robot's name and grants)."""
    if sec is None:
        return {}
    base = Path(base_dir)
    out: JSONObject = link_inserts(sec.lease_ms)
    tls = "transport/link/tls/"
    ca = _file(base, sec.ca, "ca")
    cert, key = _file(base, sec.cert, "cert"), _file(base, sec.key, "key")
    if ca:
        out[tls + "root_ca_certificate"] = ca
    if cert:
        side = "listen" if listen else "connect"
        out[f"{tls}{side}_certificate"] = cert
        out[f"{tls}{side}_private_key"] = key
        out[tls + "enable_mtls"] = sec.mtls
    out[tls + "verify_name_on_connect"] = sec.verify_name
    users = _file(base, sec.users, "users")
    if users:
        _check_dictionary(users)
        out["transport/auth/usrpwd/dictionary_file"] = users
    if sec.user is not None:
        out["transport/auth/usrpwd/user"] = sec.user
        out["transport/auth/usrpwd/password"] = _password(base, sec)
    return out


def _check_dictionary(path: str) -> None:
    for n, line in enumerate(Path(path).read_text().splitlines(), 1):
        if line.strip() and (":" not in line or not line.split(":", 1)[0] or
                             not line.split(":", 1)[1]):
            raise TransportError(f"security: users {path}:{n}: expected 'name:password'")


def _rule(rid: str, messages: list[str], flows: list[str], keys: list[str]) -> JSONObject:
    return {"id": rid, "messages": messages, "flows": flows, "permission": "allow",
            "key_exprs": keys}


def agent_rules(robot: str, agent: str, reads: list[str], commands: list[str],
                provides: Sequence[str] = ()) -> list[JSONObject]:
    """ACL rules for one remote agent of robot ``robot`` (rule ids ``<agent>.<n>``).

    The agent may: ask the control queryables (ctl/**) and get their replies, and hear
    the runtime's notices of changes (changed); send its
    puts as samples on its own ctl/put/<agent> (transport/calls.py); hold and
    watch liveliness tokens; serve its own behavior keys (bs/<agent>/**: queries, and the
    offer/result samples of a put's fast path); subscribe to the
    sensors it ``reads``; query the actuators it ``commands``; and, when it hosts
    resources (``provides``), publish their samples and serve their commands."""
    k = f"esair/{robot}"
    ingress, egress, both = ["ingress"], ["egress"], ["ingress", "egress"]
    rules = [
        _rule("ctl", ["query"], ingress, [f"{k}/ctl/**"]),
        _rule("ctl-put", ["put"], ingress, [f"{k}/ctl/put/{agent}"]),
        # the BS's subscriber on ctl/put/* must be declared to the agent, or zenoh never
        # routes the agent's puts to it (a declaration is checked as a message too)
        _rule("ctl-put-sub", ["declare_subscriber"], egress, [f"{k}/ctl/put/*"]),
        # the control queryables are declared to the agent (see "command-reply" below)
        _rule("ctl-reply", ["reply", "declare_queryable"], egress, [f"{k}/ctl/**"]),
        _rule("alive", ["liveliness_token", "liveliness_query", "declare_liveliness_subscriber"],
              both, [f"{k}/alive/**"]),
        _rule("bs", ["declare_queryable", "reply", "declare_subscriber", "put"], ingress,
              [f"{k}/bs/{agent}", f"{k}/bs/{agent}/**"]),
        _rule("bs-query", ["query", "put"], egress, [f"{k}/bs/{agent}", f"{k}/bs/{agent}/**"]),
        # the runtime's notice that a component's state changed (a remote HMI asks ls then)
        _rule("changed", ["declare_subscriber"], ingress, [f"{k}/changed"]),
        _rule("changed-put", ["put"], egress, [f"{k}/changed"]),
    ]
    if reads:
        keys = [f"{k}/sensor/{r}" for r in reads]
        rules += [_rule("read", ["declare_subscriber"], ingress, keys),
                  _rule("read-put", ["put"], egress, keys)]
    if commands:
        keys = [f"{k}/actuator/{r}" for r in commands]
        # the actuator's queryable must be declared to the agent too: a client session
        # that holds a querier (Bus.route) learns from the router's declarations who
        # answers a key, and once it has them it sends no query that none of them
        # matches (without this, only the first command got through)
        rules += [_rule("command", ["query"], ingress, keys),
                  _rule("command-reply", ["reply", "declare_queryable"], egress, keys)]
    for r in provides:
        rules += [_rule(f"sensor-{r}", ["put"], ingress, [f"{k}/sensor/{r}"]),
                  _rule(f"command-records-{r}", ["put"], ingress, [f"{k}/commands/{r}"]),
                  _rule(f"actuator-{r}", ["declare_queryable", "reply"], ingress,
                        [f"{k}/actuator/{r}"]),
                  _rule(f"actuator-{r}-query", ["query"], egress, [f"{k}/actuator/{r}"])]
    for n, rule in enumerate(rules):
        rule["id"] = f"{agent}.{n}.{rule['id']}"
    return rules


def _grant(rules: list[JSONObject], subjects: list[JSONObject],
           policies: list[JSONObject], sid: str, ident: AgentIdentity,
           mine: list[JSONObject]) -> None:
    """Add ``mine`` (rules) for the subject ``sid``, known by its certificate's CN or its
    login (``ident``), and the policy joining them."""
    rules += mine
    subject: JSONObject = {"id": sid}
    if ident.cn is not None:
        subject["cert_common_names"] = [ident.cn]
    else:
        subject["usernames"] = [ident.user]
    subjects.append(subject)
    policies.append({"rules": [r["id"] for r in mine], "subjects": [sid]})


def access_control(sec: Security | None, robot: str,
                   grants: dict[str, dict[str, list[str]]] | None = None) -> JSONObject | None:
    """The ``access_control`` config of the control center, or None when ``sec`` lists
    no agents (no ACL: the link layer alone decides who gets a session).

    ``grants``: agent -> {"reads": [...], "commands": [...], "provides": [...]}, from the
    deployment's ``allow``/``uses`` (agents not in it get only ctl/alive/bs keys)."""
    if sec is None or not (sec.agents or getattr(sec, "operators", None)):
        return None
    grants = grants or {}
    rules: list[JSONObject] = []
    subjects: list[JSONObject] = []
    policies: list[JSONObject] = []
    if sec.local:
        rules.append(_rule("local", ALL_MESSAGES, ["ingress", "egress"], ["**"]))
        subjects.append({"id": "local", "interfaces": [LOOPBACK]})
        policies.append({"rules": ["local"], "subjects": ["local"]})
    for agent, ident in sec.agents.items():
        g = grants.get(agent, {})
        mine = agent_rules(robot, agent, g.get("reads", []), g.get("commands", []),
                           g.get("provides", []))
        _grant(rules, subjects, policies, f"agent.{agent}", ident, mine)
    for op, ident in (getattr(sec, "operators", None) or {}).items():
        mine = operator_rules(robot, op)
        _grant(rules, subjects, policies, f"operator.{op}", ident, mine)
    return {"enabled": True, "default_permission": "deny", "rules": rules,
            "subjects": subjects, "policies": policies}


#: the control verbs an operator's `esair std` sends (control/control_server.py); not the agents'
#: (register, attach, report, resstate, resinfo, hello, join), which speak for a component
OPERATOR_VERBS = ("ping", "ls", "add", "remove", "add-resource", "remove-resource", "put",
                  "get", "configure", "reaction", "inspect", "state", "kind", "sample", "send")


def operator_rules(robot: str, operator: str) -> list[JSONObject]:
    """ACL rules for one operator (rule ids ``operator.<name>.<n>``): it may ask the
    control queryables of the operator's verbs and get their replies, and nothing else
    (no sensor, no actuator, no behavior key, no liveliness)."""
    keys = [f"esair/{robot}/ctl/{verb}" for verb in OPERATOR_VERBS]
    rules = [_rule("ctl", ["query"], ["ingress"], keys),
             _rule("ctl-reply", ["reply"], ["egress"], keys),
             # the control queryable (one, on ctl/*) is declared to the operator's session,
             # or its querier sends nothing (see "command-reply" in agent_rules); knowing
             # it exists lets no query through that the rule above refuses
             _rule("ctl-declared", ["declare_queryable"], ["egress"], [f"esair/{robot}/ctl/**"])]
    for n, rule in enumerate(rules):
        rule["id"] = f"operator.{operator}.{n}.{rule['id']}"
    return rules
