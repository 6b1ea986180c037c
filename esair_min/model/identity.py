"""A robot's identity on its serial link (docs/protocol.md, "Robot id").

The ``v`` reply carries ``id=BBBB``: :func:`board_set_id`, a CRC-16 of the robot's
board files (their YAML content, so comments and layout do not count, in an order that
does not depend on where the files are). Firmware generated from other board files
answers another id. The emulator (``esair emulate --pty``) appends a per-boot instance,
``id=BBBB-NNNNNNNN`` (:func:`emulated_id`), so two emulators of the same board files are
two robots to the host.
"""

from __future__ import annotations

import binascii
import json
import re

import yaml

from esair_min.errors import EsairError
from esair_min.model.robot import Robot

#: An instance: 8 lowercase hex digits (32 random bits per boot of the emulator).
INSTANCE_RE = re.compile(r"[0-9a-f]{8}")


def board_set_id(robot: Robot) -> str:
    """Four lowercase hex digits: the CRC-16/CCITT of the board files' content."""
    docs = []
    for path in sorted(set(robot.files)):
        try:
            with open(path, encoding="utf-8") as f:
                data = yaml.safe_load(f)
        except (OSError, yaml.YAMLError) as exc:
            raise EsairError(f"cannot read {path} for the robot id: {exc}") from None
        docs.append(json.dumps(data, sort_keys=True, separators=(",", ":"), default=str))
    crc = binascii.crc_hqx("\n".join(sorted(docs)).encode("utf-8"), 0xFFFF)
    return f"{crc:04x}"


def emulated_id(robot: Robot, instance: str | None) -> str:
    """The id an emulated robot answers: the board set's, then ``-instance`` if any."""
    base = board_set_id(robot)
    if instance is None:
        return base
    if not INSTANCE_RE.fullmatch(instance):
        raise EsairError(f"instance {instance!r} must be 8 lowercase hex digits")
    return f"{base}-{instance}"
