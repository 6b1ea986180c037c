"""Find a deployment: a file, a folder holding ``<folder>.yaml``, or the name of an
example shipped with esair_std (``esair_std/examples/<name>/<name>.yaml``)."""

from __future__ import annotations

from pathlib import Path

from esair_min.config.schema_errors import did_you_mean
from esair_min.errors import path_mark

from ..errors import DeployError

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def bundled_examples() -> list[str]:
    """Names of the example deployments shipped as package data."""
    if not EXAMPLES.is_dir():
        return []
    return sorted(p.name for p in EXAMPLES.iterdir() if (p / f"{p.name}.yaml").is_file())


def resolve_deployment(arg: str | Path) -> Path:
    """The deployment file ``arg`` names (see the module's doc); a path that does not
    exist is returned as is (loading it says so), a bare unknown name raises."""
    p = Path(arg)
    if p.is_dir() and (p / f"{p.name}.yaml").is_file():
        return p / f"{p.name}.yaml"
    if p.exists():
        return p
    if len(p.parts) == 1 and not p.suffix:
        if p.name in bundled_examples():
            return EXAMPLES / p.name / f"{p.name}.yaml"
        names = bundled_examples()
        raise DeployError(f"no such file, and no bundled example named '{arg}'"
                          f"{did_you_mean(str(arg), names)} (bundled: "
                          f"{', '.join(names) or 'none'})", path_mark(str(arg)))
    return p
