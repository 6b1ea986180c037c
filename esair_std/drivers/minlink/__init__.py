"""The MIN serial link: one MIN robot (PAPA-MAN) as seen from the host.

- :class:`Link` (``link.py``): the serial link itself, independent of the STD runtime;
- :class:`RobotCommands` (``commands.py``): lines built and checked from the board files;
- :func:`line_budget` (``budget.py``): the line's time budget at the robot's baud;
- the errors (``errors.py``).

See docs/std-papaman.md.
"""

from .budget import LineBudget, line_budget
from .commands import RobotCommands
from .link_errors import LinkDown, LinkError, RobotRefused
from .link import Exchange, Link

__all__ = ["Exchange", "LineBudget", "Link", "LinkDown", "LinkError", "RobotCommands",
           "RobotRefused", "line_budget"]


def __getattr__(name: str) -> type:
    # the STD driver needs the runtime's classes: imported only when asked for, so the
    # link itself works without them
    if name == "MinLink":
        from .driver import MinLink
        return MinLink
    raise AttributeError(name)
