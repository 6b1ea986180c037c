"""Find a deployment: a file, a folder holding ``<folder>.yaml`` (or a single ``.yaml``),
or the name of an example shipped with esair_std (``esair_std/examples/<name>/<name>.yaml``);
copy such an example into a folder of one's own (``esair std new NAME DIR``)."""

from __future__ import annotations

import re
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


def robot_name_for(folder: str | Path) -> str:
    """A robot name (``[a-z][a-z0-9_]*``, at most 32) from a folder's name: ``my-Bot``
    -> ``my_bot``."""
    base = re.sub(r"[^a-z0-9_]", "_", Path(folder).resolve().name.lower())
    if not base or not base[0].isalpha():
        base = "robot_" + base
    return base[:32].rstrip("_") or "robot"


def free_port() -> int:
    """A TCP port free on loopback now (never 7447, every example's)."""
    import socket
    while True:
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            port = int(s.getsockname()[1])
        if port != 7447:
            return port


def make_own(text: str, example: str, robot: str, run_as: str, endpoint: str) -> str:
    """An example's deployment file made the copy's own: its robot name, its endpoint, and
    header comments that run it as ``esair std run RUN_AS`` with other terminals told
    where it listens."""
    text = re.sub(r"^robot: .*$", f"robot: {robot}", text, count=1, flags=re.M)
    text = re.sub(r"^endpoint: .*$", f"endpoint: {endpoint}", text, count=1, flags=re.M)
    text = text.replace(f"esair std run {example} ", f"esair std run {run_as} ")
    text = re.sub(rf"esair std run {re.escape(example)}$", f"esair std run {run_as}", text,
                  flags=re.M)
    lines = text.split("\n")
    at = next(i for i, ln in enumerate(lines) if not ln.startswith("#"))
    return "\n".join([f"# Copied by `esair std new {example} {run_as}`: robot {robot!r}, "
                      f"listening on {endpoint}.",
                      f"# Other terminals: export ESAIR_STD_ENDPOINT={endpoint} (or -e "
                      f"{endpoint})", *lines[:at], *lines[at:]])


def copy_example(name: str, folder: str | Path) -> tuple[list[Path], str, str]:
    """Copy bundled example ``name`` (its deployment file and behavior modules) into
    ``folder`` (created; it must not hold files of the same names); the files written,
    the copy's robot name and endpoint. The copy is its own robot: its deployment file
    ``<folder>.yaml``, its robot named after the folder, listening on a loopback port of
    its own, its comments running it from ``folder``."""
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
    own_file = f"{dest.resolve().name}.yaml"
    targets = {f: dest / (own_file if f.name == f"{name}.yaml" else f.name) for f in files}
    clash = [t for t in targets.values() if t.exists()]
    if clash:
        raise DeployError(f"{clash[0]} exists already: choose a new folder, or move it away "
                          "(nothing was written)")
    endpoint, robot = f"tcp/127.0.0.1:{free_port()}", robot_name_for(dest)
    try:
        dest.mkdir(parents=True, exist_ok=True)
        for f, target in targets.items():
            if f.name == f"{name}.yaml":
                target.write_text(make_own(f.read_text(), name, robot, str(folder), endpoint))
            else:
                target.write_bytes(f.read_bytes())
    except OSError as exc:
        raise DeployError(f"cannot write the copy: {exc.strerror or exc}",
                          path_mark(str(dest))) from None
    return sorted(targets.values()), robot, endpoint
