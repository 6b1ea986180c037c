"""The garbage collector of a process that STD owns, settled once it has started.

CPython's full (generation 2) collection walks every container object the process
holds, with the GIL held: every thread of the process stops meanwhile. A runtime or an
agent holds some 35 000-40 000 of them after start-up (Zenoh, the robot model, the
emulator, the user's modules); a full collection of those took 33-100 ms in the runtime
and 64-273 ms in an agent here (2 cores under load), and one comes whenever the objects
that outlived two collections have grown by a quarter: a command waiting behind it waits
that long (docs/std-papaman.md, item 7). After :func:`settle` those objects sit in the
permanent generation: a full collection walks only what was made since (measured here:
0.005 ms).

Called by what owns its process: an agent once its component or resource has started
(hosts/agent_process.py) and ``esair std run`` once the runtime has (cli/run.py). A program that
runs :class:`esair_std.Runtime` as a library may call it too; the runtime does not unless
asked (``settle_heap``), as the collector is its caller's.

Only the young generations are collected first: a full collection at start-up would cost
every start of a component a long pause for a little cyclic garbage (docs/std.md, "The
heap after start-up"), so what start-up left in the old generation is frozen with the
rest (never collected, a few kB, once). Objects freed by their reference count still are.
"""

from __future__ import annotations

import gc


def settle() -> int:
    """Collect the young generations, then freeze every object (``gc.freeze``): the
    number of objects now out of the collector's walks."""
    gc.collect(1)
    gc.freeze()
    return gc.get_freeze_count()
