"""Errors of ESAIR STD: one base type (StdError), a subclass per kind of failure.

Library code raises these; only the CLI turns them into exit status 1 and one line.
"""

from __future__ import annotations

from esair_min.errors import ConfigError, EsairError


class StdError(EsairError):
    """Base of every error ESAIR STD raises on purpose."""


class Refused(StdError):
    """A registration, attach, configure or control request the policy does not allow."""


class CommandError(StdError):
    """An actuator (or a control request) refused or failed a command.

    ``resource`` names the actuator, ``message`` says why (the actuator's own words).
    """

    def __init__(self, resource: str, message: str):
        super().__init__(f"{resource}: {message}")
        self.resource = resource
        self.reason = message


class ResourceLost(StdError):
    """The resource is lost (its driver said so), removed, or its host is gone."""

    def __init__(self, resource: str, message: str):
        super().__init__(f"{resource}: {message}")
        self.resource = resource
        self.reason = message


class ComponentError(StdError):
    """A component class that cannot be imported, built or started."""


class ControlError(StdError):
    """A control request that could not be carried out (unknown name, bad request...)."""


class TransportError(StdError):
    """The engine (Zenoh) could not open a session, reach a peer, or decode a message."""


class DeployError(StdError, ConfigError):
    """A deployment file (or dict) that cannot become a valid deployment, or a
    component class named in it that cannot be imported (esair_std.deploy)."""
