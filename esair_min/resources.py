"""Find the files that ship with ESAIR MIN: firmware templates and example robots.

Installed (``pip install .``) they are the package data ``esair_min.firmware_templates``
and ``esair_min.boards``; in a source checkout they are the top-level folders.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

_REPO = Path(__file__).resolve().parent.parent


def _data_dir(package: str, folder: str) -> Path:
    """The folder of ``package`` when installed, else the checkout's ``folder``.

    The data packages have no ``__init__.py`` (they are plain folders of templates and
    YAML), so they import as namespace packages: ask the import system where they are
    rather than ``importlib.resources.files``, whose namespace result is not a path.
    """
    try:
        spec = importlib.util.find_spec(package)
    except ModuleNotFoundError:
        spec = None
    for location in (spec.submodule_search_locations or []) if spec else []:
        if Path(location).is_dir():
            return Path(location)
    return _REPO / folder


def templates_dir() -> Path:
    return _data_dir("esair_min.firmware_templates", "firmware_templates")


def examples_dir() -> Path:
    return _data_dir("esair_min.boards", "boards")


def bundled_examples() -> list[str]:
    """Names of the example robots that ship with ESAIR MIN."""
    return sorted(d.name for d in examples_dir().iterdir()
                  if d.is_dir() and any(d.glob("*.yaml")))


def resolve_robot(arg: str) -> Path:
    """A robot path as given, or the name of a bundled example (``papaman``, ``starfish``...).

    A path that does not exist is refused (ConfigError, no line:col); a bare name
    gets a did-you-mean among the bundled examples."""
    from esair_min.config.words import did_you_mean
    from esair_min.errors import ConfigError, path_mark

    p = Path(arg)
    if p.exists():
        return p
    example = examples_dir() / arg
    if not p.is_absolute() and len(p.parts) == 1 and example.is_dir():
        return example
    if len(p.parts) == 2 and p.parts[0] == "boards" and (examples_dir() / p.parts[1]).is_dir():
        return examples_dir() / p.parts[1]
    if not p.is_absolute() and len(p.parts) == 1 and not p.suffix:
        names = bundled_examples()
        hint = did_you_mean(arg, names) or (
            f" (bundled: {', '.join(names)})" if names else "")
        raise ConfigError("no such file or folder, and no bundled example robot of that "
                          f"name{hint}", path_mark(arg))
    raise ConfigError("no such file or folder", path_mark(arg))
