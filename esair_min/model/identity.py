"""A robot's identity on its serial link (docs/protocol.md, "Robot id").

An emulated robot answers ``v`` with ``id=NNNNNNNN``: its boot's *instance*, 8 random
lowercase hex digits (``esair emulate --pty``; ``--instance`` chooses them), so two
emulators of the same board files are two robots to the host. The firmware answers no
id (the PIC has no entropy source, and its flash is at its goal).
"""

from __future__ import annotations

import re

from esair_min.errors import EsairError

#: An instance: 8 lowercase hex digits (32 random bits per boot of the emulator).
INSTANCE_RE = re.compile(r"[0-9a-f]{8}")


def check_instance(instance: str) -> str:
    """``instance`` if it is 8 lowercase hex digits; else a clear error."""
    if not INSTANCE_RE.fullmatch(instance):
        raise EsairError(f"instance {instance!r} must be 8 lowercase hex digits")
    return instance
