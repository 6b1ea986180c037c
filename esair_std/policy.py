"""A behavior's ``uses`` against the resources' ``allow``: the one wording of the rule
for the deployment file (:mod:`esair_std.deploy.rules`) and for ``esair std add`` at
run time (:meth:`esair_std.runtime.Runtime.add`)."""

from __future__ import annotations

import difflib
from collections.abc import Mapping
from fnmatch import fnmatchcase

from .level import Level, best_match

#: Principals that are not behaviors: the command line's operator (``esair std send``,
#: esair_std/control/operator.py) and the browser HMI. ``allow`` may name them.
PRINCIPALS = ("operator", "hmi")


def entries_named(ref: str, entries: list[str]) -> list[str]:
    """The resource entries a ``uses`` name refers to: its first part (before any '.')
    is an entry name or a pattern over entry names."""
    top = ref.split(".", 1)[0]
    return [name for name in entries if fnmatchcase(name, top)]


def suggest(ref: str, names: list[str]) -> str:
    """`` (did you mean 'knee'?)`` for a misspelt entry (its child part kept)."""
    top, dot, rest = ref.partition(".")
    close = difflib.get_close_matches(top, names, n=1, cutoff=0.6)
    return f" (did you mean '{close[0]}{dot}{rest}'?)" if close else ""


def unknown(behavior: str, ref: str, names: list[str]) -> str:
    return f"behavior '{behavior}' uses unknown resource '{ref}'{suggest(ref, names)}"


def grant_problem(behavior: str, ref: str, level: Level,
                  allows: Mapping[str, Mapping[str, Level | str]]) -> str | None:
    """Why the resources ``ref`` names (``allows``: entry -> its allow table) do not
    grant ``behavior`` the ``level`` (None: one of them does)."""
    entries = list(allows)
    grants = [g for e in entries if (g := best_match(allows[e], behavior)) is not None]
    best = max(grants, default=None)
    if best is not None and best >= level:
        return None
    head = f"behavior '{behavior}' uses '{ref}' at level '{level.name}', but "
    if len(entries) == 1:
        res = f"resource '{entries[0]}'"
        if best is None:
            return f"{head}{res} does not allow it (add '{behavior}: {level.name}' to its allow)"
        return f"{head}{res} allows it only up to '{best.name}'"
    those = f"the resources it names ({', '.join(entries)})"
    if best is None:
        return f"{head}none of {those} allows it"
    return f"{head}{those} allow it only up to '{best.name}'"


def uses_problem(behavior: str, uses: Mapping[str, Level | str],
                 allows: Mapping[str, Mapping[str, Level | str]]) -> str | None:
    """The first entry of ``uses`` the deployed resources (``allows``: entry -> allow)
    cannot honour, in the deployment check's words; None when all can."""
    names = list(allows)
    for ref, level in uses.items():
        named = entries_named(ref, names)
        if not named:
            return unknown(behavior, ref, names)
        why = grant_problem(behavior, ref, Level.parse(level), {e: allows[e] for e in named})
        if why is not None:
            return why
    return None
