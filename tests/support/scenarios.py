"""Scenarios of the emulated PAPA-MAN made for the tests from the bundled ones."""

from __future__ import annotations

from pathlib import Path

import yaml

PUSH = Path(__file__).resolve().parents[2] / "boards" / "papaman" / "scenarios" / "push.yaml"
SOONER_MS = 900


def push_soon(folder: Path) -> Path:
    """boards/papaman's push scenario with its push SOONER_MS earlier after each play
    (tipping 0.2 s after it, not 1.1 s): the same values in the same order, each step
    as long as there. Written to ``folder``; its path."""
    push = yaml.safe_load(PUSH.read_text())
    first, *rest = push["steps"]
    assert first["at_ms"] == 0 and min(s["at_ms"] for s in rest) > SOONER_MS, push
    push["steps"] = [first] + [dict(s, at_ms=s["at_ms"] - SOONER_MS) for s in rest]
    path = folder / "push-soon.yaml"
    path.write_text(yaml.safe_dump(push))
    return path
