"""Example deployments shipped with ESAIR STD (package data): ``lab`` runs every class
with simulated drivers. ``esair std run lab`` finds them by name."""

from __future__ import annotations

from pathlib import Path

HERE = Path(__file__).resolve().parent


def names() -> list[str]:
    return sorted(p.name for p in HERE.iterdir() if (p / f"{p.name}.yaml").is_file())


def resolve_deployment(arg: str) -> Path:
    """A deployment path as given, or the name of a bundled example (``lab``)."""
    p = Path(arg)
    if p.exists():
        return p
    if not p.is_absolute() and len(p.parts) == 1 and (HERE / arg / f"{arg}.yaml").is_file():
        return HERE / arg / f"{arg}.yaml"
    return p
