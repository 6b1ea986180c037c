"""The Zenoh key layout of one robot (documented in docs/std.md).

    esair/<robot>/ctl/<verb>           control queryables of the runtime
    esair/<robot>/bs/<behavior>        BS -> behavior (offer, provide, state, detached...)
    esair/<robot>/ctl/put/<sender>     sender -> BS: a put from a component process (sample)
    esair/<robot>/bs/<behavior>/offer  BS -> behavior: that put's first offer (sample)
    esair/<robot>/bs/<behavior>/result behavior -> BS: the offer's answer (sample)
    esair/<robot>/bs/<sender>/answer   BS -> sender: the put's outcome (sample)
    esair/<robot>/bs/<behavior>/credit behavior -> BS: open or not, full or not, room reserved (sample)
    esair/<robot>/bs/<behavior>/deliver BS -> behavior: a put into reserved room (sample)
    esair/<robot>/rs/<entry>           RS -> resource host (configure, grant, revoke...)
    esair/<robot>/sensor/<resource>    sensor samples, published by the sensor's host
    esair/<robot>/actuator/<resource>  commands, a queryable on the actuator's host
    esair/<robot>/commands/<entry>     the commands an entry's actuators ran, and their
                                       outcomes, in batches (published, for recorders
                                       and the HMI: transport/records.py)
    esair/<robot>/alive/<kind>/<name>  liveliness tokens
    esair/<robot>/changed              the runtime: a component's state changed (a
                                       notice, ``{"v": n}``; what changed: ``ls``)
"""

from __future__ import annotations


def root(robot: str) -> str:
    return f"esair/{robot}"


def ctl(robot: str, verb: str) -> str:
    return f"esair/{robot}/ctl/{verb}"


def is_ctl(key: str) -> bool:
    """A key of a runtime's control endpoint (:func:`ctl`, any robot)."""
    parts = key.split("/")
    return len(parts) > 3 and parts[0] == "esair" and parts[2] == "ctl"


def bs(robot: str, name: str) -> str:
    return f"esair/{robot}/bs/{name}"


def ctl_put(robot: str, sender: str) -> str:
    return f"esair/{robot}/ctl/put/{sender}"


def bs_answer(robot: str, name: str) -> str:
    return f"esair/{robot}/bs/{name}/answer"


def bs_offer(robot: str, name: str) -> str:
    return f"esair/{robot}/bs/{name}/offer"


def bs_result(robot: str, name: str) -> str:
    return f"esair/{robot}/bs/{name}/result"


def bs_credit(robot: str, name: str) -> str:
    return f"esair/{robot}/bs/{name}/credit"


def bs_deliver(robot: str, name: str) -> str:
    return f"esair/{robot}/bs/{name}/deliver"


def rs(robot: str, entry: str) -> str:
    return f"esair/{robot}/rs/{entry}"


def sensor(robot: str, resource: str) -> str:
    return f"esair/{robot}/sensor/{resource}"


def actuator(robot: str, resource: str) -> str:
    return f"esair/{robot}/actuator/{resource}"


def commands(robot: str, entry: str) -> str:
    """An entry's command records, in batches (transport/records.py)."""
    return f"esair/{robot}/commands/{entry}"


def commands_all(robot: str) -> str:
    return f"esair/{robot}/commands/*"


def alive(robot: str, kind: str, name: str) -> str:
    return f"esair/{robot}/alive/{kind}/{name}"


def alive_all(robot: str) -> str:
    return f"esair/{robot}/alive/**"


def name_in(key: str, from_end: int = 1) -> str:
    """The chunk of ``key`` that names a component: the last (``from_end=1``), the
    one before it (2)..."""
    return key.rsplit("/", from_end)[-from_end]


def parse_alive(robot: str, key: str) -> tuple[str, str] | None:
    """(kind, name) of an alive key, None if it is not one."""
    prefix = f"esair/{robot}/alive/"
    if not key.startswith(prefix):
        return None
    kind, _, name = key[len(prefix):].partition("/")
    return (kind, name) if name else None


def changed(robot: str) -> str:
    return f"esair/{robot}/changed"


def latch(robot: str) -> str:
    """The latched STOP's state, published at each change: ``{"stopped": bool, "by",
    "t", "at", "reason"}`` (latch.py)."""
    return f"esair/{robot}/latch"
