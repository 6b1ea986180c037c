"""The drive board's Python core run over a stimulus script, writing the trace the
generated host port writes (firmware_templates/drive/ports/host): ``write REG B0 ...``
(hex), ``tick N``; after each tick ``T`` and ``duty/dir`` of every motor."""

from __future__ import annotations

from typing import Any

from esair_min.components.dc_motor.core import DriveCore


def run_script(board: Any, script: str) -> list[str]:
    drive = DriveCore(board)
    out: list[str] = []
    for text in script.splitlines():
        if text.startswith("write "):
            first, *data = (int(t, 16) for t in text[6:].split())
            drive.write(first, bytes(data))
        elif text.startswith("tick "):
            for _ in range(int(text[5:])):
                drive.tick()
                out.append("T" + "".join(f" {m.duty}/{int(m.forward)}" for m in drive.motors))
        elif text:
            raise ValueError(f"unknown script line {text!r}")
    return out
