"""``esair std ls``: one row per component, every row with the same keys.

``name, kind, state, pid, host, restarts, reason, class, parent, attached, detached``
(``detached``: the resources a behavior was detached from and not attached to again;
empty for a resource): a driver's
entry is a row of its own (kind ``driver``, its state from its children: ``lost`` with
the first lost child's reason when one is, else ``ready``), each child names it as
``parent``. ``attached`` is, for a sensor, who is attached to it through the SC; for an
actuator, who is registered to command it; for a behavior or a reaction, the resources
it is attached to (read through the SC, or registered at command level).
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Iterable

from ..level import Level
from ..transport.codec import JSONObject

if TYPE_CHECKING:  # pragma: no cover
    from ..runtime_view import RuntimeView

KEYS = ("name", "kind", "state", "pid", "host", "restarts", "reason", "class", "parent",
        "attached", "detached")


def components(rt: RuntimeView) -> list[JSONObject]:
    """The rows of ``rt`` (a Runtime): behaviors and reactions, then each resource entry
    (a driver's row before its children's), in deployment order."""
    readers: dict[str, set[str]] = {}      # resource -> who reads it
    commanders: dict[str, set[str]] = {}   # resource -> who may command it
    for res in list(rt.rs.resources):
        readers[res] = set(rt.sc.attached_to(res))
    for (who, res), level in list(rt.rs.grants.items()):
        if level >= Level.command:
            commanders.setdefault(res, set()).add(who)
    uses: dict[str, set[str]] = {}
    for table in (readers, commanders):
        for res, whos in table.items():
            for who in whos:
                uses.setdefault(who, set()).add(res)
    rows: list[JSONObject] = []
    listed = rt.ls()
    for row in listed:
        if row["kind"] in ("behavior", "reaction"):
            rows.append(_row(row, parent="", attached=uses.get(str(row["name"]), ())))
    kids_of: dict[str, list[JSONObject]] = {}
    for row in listed:
        if row["kind"] not in ("behavior", "reaction"):
            name = str(row["name"])
            entry = rt.rs.resources.get(name, (name, ""))[0]
            kids_of.setdefault(entry, []).append(row)
    for entry, (spec, host) in list(rt.rs.entries.items()):
        kids = kids_of.get(entry, [])
        if not kids:        # still opening (or failed to): no sensor or actuator of it yet
            state, reason = rt.rs.states.get(entry, (host.state, ""))
            rows.append(dict(name=entry, kind=rt.rs.kind_of(entry) or "resource",
                             state=state, pid=getattr(host, "pid", None) or os.getpid(),
                             host=rt.hostname, restarts=0, reason=reason,
                             **{"class": spec.class_path}, parent="", attached=[],
                             detached=[]))
            continue
        driver = not (len(kids) == 1 and kids[0]["name"] == entry)
        if driver:
            lost = [k for k in kids if k["state"] != "ready"]
            first = kids[0] if kids else {}
            rows.append(dict(name=entry, kind="driver",
                             state=lost[0]["state"] if lost else "ready",
                             pid=first.get("pid", os.getpid()),
                             host=first.get("host", rt.hostname),
                             restarts=first.get("restarts", 0),
                             reason=lost[0]["reason"] if lost else "",
                             **{"class": spec.class_path}, parent="", attached=[],
                             detached=[]))
        for k in kids:
            who = (commanders if k["kind"] == "actuator" else readers).get(str(k["name"]), ())
            rows.append(_row(k, parent=entry if driver else "", attached=who))
    return rows


def _row(row: JSONObject, parent: str, attached: Iterable[str]) -> JSONObject:
    out = {k: row.get(k, "") for k in KEYS}
    detached = row.get("detached") or []
    out.update(parent=parent, attached=sorted(attached), restarts=row.get("restarts", 0),
               detached=list(detached) if isinstance(detached, list) else [])
    return out
