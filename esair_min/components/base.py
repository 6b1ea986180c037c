"""What a device kind declares (:class:`Component`) and what its rules may ask of the
validator (:class:`Checker`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Callable, Iterable, NamedTuple, NoReturn, Protocol

if TYPE_CHECKING:
    from esair_min.model.types import Section


class Checker(Protocol):
    """The validator as the kinds see it: an error at a node of a board's file. ``fail``
    stops the kind's rule (its next checks depend on this one); ``report`` collects the
    error and the rule goes on. Either way the validator reports every error it found."""

    def fail(self, board: Any, loc: Iterable[Any], message: str, *,
             key: bool = False) -> NoReturn:
        ...

    def report(self, board: Any, loc: Iterable[Any], message: str, *,
               key: bool = False) -> None:
        ...

    def rule(self, check: Callable[..., None], *args: Any) -> None:
        """Run ``check(*args)``, collecting the error its ``fail`` raises (one rule an
        item: every item's first error is reported)."""
        ...

    def doc(self, board: Any) -> Any:
        ...

    def unique(self, board: Any, section: str, field: str) -> None:
        ...


class PinClaim(NamedTuple):
    """A pin an item uses: ``what`` names it in messages, ``loc`` is the node (from the
    item) an error about it points at."""

    pin: str
    what: str
    loc: tuple[Any, ...]


def _no_rules(checker: Checker, board: Any) -> None:
    return None


def _no_robot_rules(checker: Checker, central: Any, by_role: dict[str, Any]) -> None:
    return None


def _no_pins(item: Any) -> list[PinClaim]:
    return []


@dataclass(frozen=True)
class Component:
    """One device kind of the board model.

    ``section`` is the board-file key holding a list of ``schema`` items, allowed on
    boards of ``roles``; ``unique`` names the fields no two items of a board share;
    ``registers_per_item`` is what each item adds to its board's I2C register map.
    ``board_rules(checker, board)`` and ``robot_rules(checker, central, by_role)`` raise
    through the checker; ``pins(item)`` lists the pins an item claims. A kind with
    ``many=False`` is one optional settings object (``base:``) instead of a list;
    ``summary(board)`` gives the lines ``esair check`` prints about it.
    """

    kind: str
    section: str
    schema: type[Section]
    description: str
    roles: tuple[str, ...]
    unique: tuple[str, ...] = ()
    registers_per_item: int = 0
    board_rules: Callable[[Checker, Any], None] = _no_rules
    robot_rules: Callable[[Checker, Any, dict[str, Any]], None] = _no_robot_rules
    pins: Callable[[Any], list[PinClaim]] = _no_pins
    many: bool = True
    generated: bool = True        # the generator has C templates for it
    summary: Callable[[Any], list[str]] | None = None
    extra: dict[str, Any] = field(default_factory=dict)

    def items(self, board: Any) -> tuple[Any, ...]:
        """The kind's items on ``board``: its list, or its one settings object."""
        value = getattr(board, self.section)
        if self.many:
            return value
        return () if value is None else (value,)

    def item_loc(self, i: int) -> tuple[Any, ...]:
        """Where item ``i`` is in the board file."""
        return (self.section, i) if self.many else (self.section,)
