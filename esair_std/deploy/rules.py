"""Rules across entries of a valid deployment: what ``uses`` and ``resources`` name
must exist, and a behavior's ``uses`` level must be granted by the resource's
``allow`` -- checked when the file is loaded, so a bad policy never reaches the RS.

``allow`` may name behaviors the file does not list: they may be added while the
robot runs (``esair std add``). :func:`notes` lists those names for ``esair std
check`` (with a did-you-mean when one looks like a listed behavior's typo).
"""

from __future__ import annotations

import difflib

from esair_min.errors import Mark
from esair_min.config.words import quote
from esair_min.config.yamlload import Document

from ..errors import DeployError
from ..policy import PRINCIPALS, entries_named, grant_problem, suggest, unknown
from .model import Deployment

WILDCARDS = set("*?[")


def resource_entries(dep: Deployment, ref: str) -> list[str]:
    """The resource entries a ``uses``/``resources`` name refers to: its first part
    (before any '.') is an entry name or a pattern over entry names."""
    return entries_named(ref, list(dep.resources))


def check_rules(dep: Deployment, doc: Document) -> None:
    """Raise DeployError at the first reference or level the deployment cannot honour."""
    names = list(dep.resources)
    for spec in dep.behaviors.values():
        for ref, level in spec.uses.items():
            loc = ("behaviors", spec.name, "uses", ref)
            entries = resource_entries(dep, ref)
            if not entries:
                raise DeployError(unknown(spec.name, ref, names), doc.mark(loc, key=True))
            why = grant_problem(spec.name, ref, level,
                                {e: dep.resources[e].allow for e in entries})
            if why is not None:
                raise DeployError(why, doc.mark(loc))
    for spec in dep.reactions.values():
        for i, ref in enumerate(spec.resources):
            if not resource_entries(dep, ref):
                raise DeployError(f"reaction {quote(spec.name)} names unknown resource "
                                  f"{quote(ref)}{suggest(ref, names)}",
                                  doc.mark(("reactions", spec.name, "resources", i)))


def notes(dep: Deployment, doc: Document) -> list[tuple[Mark, str]]:
    """Remarks that are not errors: ``allow`` names no behavior of this file lists."""
    out: list[tuple[Mark, str]] = []
    behaviors = list(dep.behaviors)
    for res in dep.resources.values():
        for pattern in res.allow:
            if WILDCARDS & set(pattern) or pattern in dep.behaviors or pattern in PRINCIPALS:
                continue
            close = difflib.get_close_matches(pattern, behaviors, n=1, cutoff=0.6)
            hint = f" (did you mean '{close[0]}'?)" if close else ""
            out.append((doc.mark(("resources", res.name, "allow", pattern), key=True),
                        f"resource {quote(res.name)} allows {quote(pattern)}, which is not "
                        f"a behavior of this file{hint}; one added at run time may use it"))
    return out

