"""``esair new ROBOT DIR``: a bundled MIN robot's board files copied into DIR, renamed
after the folder (the robot's name is its folder's: docs/board-format.md)."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

from esair_min.config.words import did_you_mean
from esair_min.errors import ConfigError, path_mark
from esair_min.resources import bundled_examples, examples_dir

#: how each bundled robot names itself in its board files' descriptions and comments
_SPELLINGS = {"papaman": ("PAPA-MAN", "papaman"), "starfish": ("STARFISH", "starfish")}


def _family(name: str) -> str:
    return name.split("-", 1)[0]


def renamed(text: str, source: str, new_name: str) -> str:
    """A board file's text with the bundled robot's name replaced by ``new_name`` in its
    ``description:`` values and comments (the keys and values the model reads stay)."""
    names = _SPELLINGS.get(_family(source), (source,))
    pattern = re.compile("|".join(re.escape(n) for n in names))
    out = []
    for line in text.splitlines(keepends=True):
        stripped = line.lstrip()
        if stripped.startswith("#") or stripped.startswith("description:"):
            line = pattern.sub(new_name, line)
        elif "#" in line:
            code, _, comment = line.partition("#")
            line = code + "#" + pattern.sub(new_name, comment)
        out.append(line)
    return "".join(out)


def copy_robot(source: str, folder: str | Path) -> list[Path]:
    """Copy bundled robot ``source``'s board files (and its ``scenarios/``) into
    ``folder`` (created; an existing one must be empty); the files written."""
    names = bundled_examples()
    if source not in names:
        raise ConfigError(f"no bundled robot named '{source}'{did_you_mean(source, names)} "
                          f"(bundled: {', '.join(names)})")
    dest = Path(folder)
    if dest.exists() and (not dest.is_dir() or any(dest.iterdir())):
        raise ConfigError("exists and is not an empty folder", path_mark(str(dest)))
    new_name = dest.resolve().name
    src = examples_dir() / source
    written = []
    dest.mkdir(parents=True, exist_ok=True)
    header = (f"# {new_name}: made with `esair new {source} {new_name}` from ESAIR's "
              f"bundled robot {source}.\n")
    for path in sorted(src.glob("*.yaml")):
        out = dest / path.name
        out.write_text(header + renamed(path.read_text(), source, new_name))
        written.append(out)
    if (src / "scenarios").is_dir():
        shutil.copytree(src / "scenarios", dest / "scenarios")
        written += sorted((dest / "scenarios").rglob("*.yaml"))
    return written
