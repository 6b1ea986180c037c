"""The Zenoh key layout of one robot (documented in docs/std.md).

    esair/<robot>/ctl/<verb>           control queryables of the runtime
    esair/<robot>/bs/<behavior>        BS -> behavior (offer, provide, state, detached...)
    esair/<robot>/rs/<entry>           RS -> resource host (configure, grant, revoke...)
    esair/<robot>/sensor/<resource>    sensor samples, published by the sensor's host
    esair/<robot>/actuator/<resource>  commands, a queryable on the actuator's host
    esair/<robot>/alive/<kind>/<name>  liveliness tokens
"""

from __future__ import annotations


def root(robot: str) -> str:
    return f"esair/{robot}"


def ctl(robot: str, verb: str) -> str:
    return f"esair/{robot}/ctl/{verb}"


def bs(robot: str, name: str) -> str:
    return f"esair/{robot}/bs/{name}"


def rs(robot: str, entry: str) -> str:
    return f"esair/{robot}/rs/{entry}"


def sensor(robot: str, resource: str) -> str:
    return f"esair/{robot}/sensor/{resource}"


def actuator(robot: str, resource: str) -> str:
    return f"esair/{robot}/actuator/{resource}"


def alive(robot: str, kind: str, name: str) -> str:
    return f"esair/{robot}/alive/{kind}/{name}"


def alive_all(robot: str) -> str:
    return f"esair/{robot}/alive/**"


def parse_alive(robot: str, key: str) -> tuple[str, str] | None:
    """(kind, name) of an alive key, None if it is not one."""
    prefix = f"esair/{robot}/alive/"
    if not key.startswith(prefix):
        return None
    kind, _, name = key[len(prefix):].partition("/")
    return (kind, name) if name else None
