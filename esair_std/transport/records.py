"""Command records on the bus: each command an actuator ran and its outcome, for
recorders (``esair std record``, the HMI's ● rec) and the HMI's pose and sliders.

The host of a resource entry (an actuator, or a driver and its children) publishes its
actuators' records in batches, on ``esair/<robot>/commands/<entry>`` (keys.commands): a JSON list of
``{"r": actuator, "seq": n, "t": when, "v": {"command": ..., "ok" | "error": ..., "by":
sender}}`` (``seq`` the actuator's command number, ``t`` when the command reached the
host, time.time(); ``by`` who sent it, absent for the host's own halt on a STOP). A
batch leaves at most :data:`BATCH_S` after its first record, or at once with
:data:`BATCH_MAX` records: at PAPA-MAN's ~120 servo commands a second that is ~20
messages a second in place of ~120, and each message costs its receiver about the same
whatever it holds (Zenoh's receive path: bench/hmi_figures.py, docs/hmi.md). A listener takes
from a batch only the records of that entry's own actuators (``<entry>`` or
``<entry>.<child>``; the ACL lets a host publish its own entry's key only), so a host
cannot speak for another's actuators.
"""

from __future__ import annotations

from .codec import JSON, JSONObject

BATCH_S = 0.05        # a record waits at most this long for others to share its message
BATCH_MAX = 256       # ... and goes at once with this many


def record(resource: str, seq: int, t: float, outcome: JSONObject,
           command: JSON) -> JSONObject:
    return {"r": resource, "seq": seq, "t": t, "v": dict(outcome, command=command)}


def unpack(key: str, obj: JSON) -> tuple[list[tuple[str, JSONObject]], int]:
    """The ``(actuator, {seq, t, v})`` of a batch heard on ``key``, and how many of its
    items were not records of that entry's actuators (left out)."""
    entry = key.rsplit("/", 1)[-1]
    if not isinstance(obj, list):
        return [], 1
    out: list[tuple[str, JSONObject]] = []
    bad = 0
    for item in obj:
        r = item.get("r") if isinstance(item, dict) else None
        v = item.get("v") if isinstance(item, dict) else None
        if (not isinstance(item, dict) or not isinstance(r, str)
                or not (r == entry or r.startswith(entry + ".")) or not isinstance(v, dict)):
            bad += 1
            continue
        out.append((r, {"seq": item.get("seq"), "t": item.get("t"), "v": v}))
    return out, bad
