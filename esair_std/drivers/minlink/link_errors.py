"""The MIN link's errors: one type for the layer (:class:`LinkError`) and its refinements.

Library code raises these; the STD driver turns them into the runtime's
``CommandError`` / ``ResourceLost`` for the behavior that sent the command.
"""

from __future__ import annotations

from esair_min.errors import EsairError
from esair_min.core.protocol import Code


class LinkError(EsairError):
    """A command that was refused before sending, or a link that cannot be used."""


class LinkDown(LinkError):
    """The link is down: the command was not sent, or its reply cannot come any more."""


class RobotRefused(LinkError):
    """The robot answered a command with an ``Enn`` reply (docs/protocol.md)."""

    def __init__(self, command: str, code: Code, text: str):
        super().__init__(f"robot refused {command!r}: {text}")
        self.command = command
        self.code = code
        self.text = text


class DifferentRobot(LinkDown):
    """Another robot answers on the port: the link stays down (nothing is sent to it)."""


class PtyGone(DifferentRobot):
    """The pty the link had went away and its number now leads to a pty made since,
    another program's: the link does not open it (not a byte, not a read)."""


class Expired(LinkError):
    """A command that could not be written within its deadline: dropped, never sent."""


class Held(LinkError):
    """The robot is STOPPED (the runtime's latched stop): the line was not sent."""
