"""Writes esair_std/record/foxschemas.py: the protobuf schemas (FileDescriptorSets) of
the Foxglove messages ESAIR sends, from the foxglove-sdk package, so that the live
server and the recorder advertise them without importing the SDK (docs/foxglove.md,
"What it costs"). tests/std/test_foxproto.py checks the file against the SDK.

Run: python scripts/foxglove_schemas.py"""

from __future__ import annotations

import base64
from pathlib import Path

from foxglove import messages as fm

NAMES = ["Log", "PoseInFrame", "FrameTransform", "CompressedImage", "SceneUpdate"]
OUT = Path(__file__).resolve().parent.parent / "esair_std" / "record" / "foxschemas.py"


def text() -> str:
    lines = ['"""The protobuf schemas (FileDescriptorSets, base64) of the Foxglove messages ESAIR',
             "sends, as foxglove-sdk gives them; written by scripts/foxglove_schemas.py (do not",
             'edit; tests/std/test_foxproto.py checks them against the SDK)."""', "",
             "SCHEMAS = {"]
    for name in NAMES:
        data = base64.b64encode(bytes(getattr(fm, name).get_schema().data)).decode()
        lines.append(f'    "foxglove.{name}": (')
        lines += [f'        "{data[i:i + 96]}"' for i in range(0, len(data), 96)]
        lines.append("    ),")
    lines.append("}")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    OUT.write_text(text())
    print(f"wrote {OUT}")
