"""The deployment's optional ``security:`` section (docs/std-network.md, "Security").

What keeps strangers away from the robot's control endpoint: TLS with client
certificates (``ca``/``cert``/``key``, ``mtls``), Zenoh user/password logins (``users``
on the control center, ``user``/``password_file`` on an agent), the link lease, and the
remote agents let in (``agents``: Zenoh access control, default deny, and the RS's own
identity check). Paths are relative to the deployment file's folder.
:mod:`esair_std.transport.security_config` turns this into Zenoh configuration.
"""

from __future__ import annotations

from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field, StrictBool, StrictStr, model_validator

AGENT_NAME = r"^[a-z][a-z0-9_]{0,31}$"            # a behavior / resource name
IDENT = r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$"     # a certificate CN or a login


class AgentIdentity(BaseModel):
    """Who a remote agent is on the link: its certificate's CN or its login."""

    model_config = ConfigDict(frozen=True, extra="forbid", defer_build=True)
    cn: StrictStr | None = Field(None, pattern=IDENT,
                                 description="common name of the agent's client certificate")
    user: StrictStr | None = Field(None, pattern=IDENT,
                                   description="the agent's login (a line of `users`)")

    @model_validator(mode="after")
    def _one(self) -> AgentIdentity:
        if (self.cn is None) == (self.user is None):
            raise ValueError("give exactly one of 'cn' (certificate common name) or 'user'")
        return self


class SecuritySpec(BaseModel):
    """Transport security of the runtime's sessions."""

    model_config = ConfigDict(frozen=True, extra="forbid", defer_build=True)
    ca: Path | None = Field(None, description="the CA that signed the peers' certificates (PEM)")
    cert: Path | None = Field(None, description="this computer's certificate (PEM)")
    key: Path | None = Field(None, description="this computer's private key (PEM)")
    mtls: StrictBool = Field(True, description="peers must show a certificate signed by ca")
    verify_name: StrictBool = Field(True, description="the server certificate must name the "
                                                      "host connected to")
    users: Path | None = Field(None, description="'name:password' lines: every peer logs in")
    user: StrictStr | None = Field(None, pattern=IDENT,
                                   description="this side's login (an agent's)")
    password_file: Path | None = Field(None, description="file holding this side's password")
    lease_ms: int = Field(2000, ge=200, le=60000,
                          description="a silent computer's session is dropped after this")
    local: StrictBool = Field(True, description="processes of this computer (loopback) are "
                                                "trusted by the access control")
    agents: dict[str, AgentIdentity] = Field(
        default_factory=dict,
        description="remote agents let in, by name: {cn: ...} or {user: ...} "
                    "(Zenoh access control, default deny; checked again at registration)")
    operators: dict[str, AgentIdentity] = Field(
        default_factory=dict,
        description="operators let in on the main endpoint, by name: {cn: ...} or {user: ...} "
                    "(their `esair std` control verbs only; turns the access control on)")

    @model_validator(mode="after")
    def _consistent(self) -> SecuritySpec:
        if (self.cert is None) != (self.key is None):
            raise ValueError("'cert' and 'key' go together")
        if self.mtls and self.cert is not None and self.ca is None:
            raise ValueError("mtls needs 'ca' (the authority that signed the peers' certificates)")
        if (self.user is None) != (self.password_file is None):
            raise ValueError("'user' and 'password_file' go together")
        import re
        bad = [a for a in self.agents if not re.match(AGENT_NAME, a)]
        if bad:
            raise ValueError(f"agent name {bad[0]!r} is not a component name "
                             "([a-z][a-z0-9_]*, at most 32 characters)")
        bad = [a for a in self.operators if not re.match(AGENT_NAME, a)]
        if bad:
            raise ValueError(f"operator name {bad[0]!r} is not a name "
                             "([a-z][a-z0-9_]*, at most 32 characters)")
        return self
