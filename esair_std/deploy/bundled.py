"""Find a deployment: a file, a folder holding ``<folder>.yaml`` (or a single ``.yaml``),
or the name of an example shipped with esair_std (``esair_std/examples/<name>/<name>.yaml``);
copy such an example into a folder of one's own (``esair std new NAME DIR``)."""

from __future__ import annotations

from pathlib import Path

from esair_min.config.words import did_you_mean
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
    if p.is_dir():                       # a copy made by `esair std new NAME DIR`: its
        found = sorted(p.glob("*.yaml"))  # one file, or NAME.yaml beside data (a room)
        named = [f for f in found if f.stem in bundled_examples()]
        if len(found) == 1 or len(named) == 1:
            return (found if len(found) == 1 else named)[0]
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


def copy_example(name: str, folder: str | Path) -> list[Path]:
    """Copy bundled example ``name`` (its deployment file and behavior modules) into
    ``folder`` (created; it must not hold files of the same names); the files written."""
    names = bundled_examples()
    if name not in names:
        raise DeployError(f"no bundled example named '{name}'{did_you_mean(name, names)} "
                          f"(bundled: {', '.join(names) or 'none'})")
    src = EXAMPLES / name
    files = sorted(f for f in src.iterdir() if f.is_file() and f.suffix in (".yaml", ".py")
                   and f.name != "__init__.py")
    dest = Path(folder)
    if dest.exists() and not dest.is_dir():
        raise DeployError("is a file, not a folder", path_mark(str(dest)))
    clash = [dest / f.name for f in files if (dest / f.name).exists()]
    if clash:
        raise DeployError(f"{clash[0]} exists already: choose a new folder, or move it away "
                          "(nothing was written)")
    try:
        dest.mkdir(parents=True, exist_ok=True)
        for f in files:
            (dest / f.name).write_bytes(f.read_bytes())
    except OSError as exc:
        raise DeployError(f"cannot write the copy: {exc.strerror or exc}",
                          path_mark(str(dest))) from None
    return [dest / f.name for f in files]
