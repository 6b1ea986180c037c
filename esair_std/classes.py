"""Import the class a deployment entry or a runtime spec names (``module:Class``):
the one class importer of ESAIR STD (the deployment check, the runtime, agents).

The module is imported from the deployment file's folder first, then ``sys.path``:
only the module the ``class:`` names is looked up in the folder first (a finder at the
front of ``sys.meta_path`` knows those names, :class:`_OwnModules`); the folder is
added at the END of ``sys.path``, so the user's modules still import their neighbours,
while a file of the folder named like an installed module (``numpy.py``) shadows
nothing. A module of the same name already imported from elsewhere is imported afresh
from the folder. Every failure is one
:class:`DeployError` at the entry's ``class:`` value, with a did-you-mean.
Imports are serialised by a lock (``sys.path`` and ``sys.modules`` are global).

:func:`component_class` is the runtime's door to it: a spec that travelled as JSON
has no mark, only its ``where`` text, and a failure there is a component failure
(:class:`ComponentError`). This module imports neither pydantic nor the deployment
model, so an agent process stays small; what only an error message needs (difflib,
pkgutil, traceback) is imported when the error happens.
"""

from __future__ import annotations

import importlib
import os
import re
import sys
import threading
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Protocol, Sequence, cast

if TYPE_CHECKING:  # pragma: no cover
    from importlib.machinery import ModuleSpec

from esair_min.errors import Mark

from .errors import ComponentError, DeployError

#: ``module:Class`` -- a dotted module path, a colon, a class name; also the pattern
#: of the deployment model's ``class:`` field (esair_std.deploy.model)
CLASS_PATTERN = r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*:[A-Za-z_][A-Za-z0-9_]*$"

_lock = threading.RLock()


class _OwnModules:
    """A meta path finder: the deployments' own top-level modules (those a ``class:``
    names) from their folders, before ``sys.path``; nothing else."""

    def __init__(self) -> None:
        self.folders: dict[str, str] = {}

    def find_spec(self, fullname: str, path: Sequence[str] | None = None,
                  target: ModuleType | None = None) -> ModuleSpec | None:
        folder = self.folders.get(fullname)
        if folder is None or path is not None:
            return None
        from importlib.machinery import PathFinder
        return PathFinder.find_spec(fullname, [folder])

    def invalidate_caches(self) -> None:
        pass


_own = _OwnModules()


class _ClassEntry(Protocol):
    """What load_class reads of a loaded deployment's entry (deploy/model.py)."""

    class_path: str
    base_dir: str | Path | None
    class_mark: Mark | None


def load_class(spec: object, base_dir: str | Path | None = None, *,
               mark: Mark | None = None, expect: tuple[type, ...] | type | None = None,
               ) -> type:
    """The class ``spec`` names: a spec of a loaded deployment (its ``class_path``,
    ``base_dir`` and ``class_mark`` are used) or a ``module:Class`` string.

    ``base_dir`` (or the spec's) is searched before ``sys.path``; ``expect`` is the
    base class(es) the class must derive from. Raises DeployError (at ``mark`` or the
    spec's ``class:`` value) for a malformed path, a missing or failing module, a
    missing attribute, something that is not a class, or a wrong base class.
    """
    if not isinstance(spec, str) and hasattr(spec, "class_mark"):   # a ComponentSpec
        entry = cast(_ClassEntry, spec)
        path, base, mark = entry.class_path, base_dir or entry.base_dir, mark or entry.class_mark
    else:
        path, base = spec, base_dir
    if not isinstance(path, str) or not re.match(CLASS_PATTERN, path):
        raise DeployError(f"'class' must be module:Class (a module path, a colon, a class "
                          f"name), not {path!r}", mark)
    module_name, class_name = path.split(":")
    with _lock:
        module = _import(module_name, Path(base).resolve() if base else None, mark)
    cls = getattr(module, class_name, None)
    if cls is None:
        import difflib
        names = [n for n, v in vars(module).items() if isinstance(v, type)]
        close = difflib.get_close_matches(class_name, names, n=1, cutoff=0.6)
        hint = f" (did you mean '{close[0]}'?)" if close else ""
        raise DeployError(f"module {quote(module_name)} has no class {quote(class_name)}"
                          f"{hint}", mark)
    if not isinstance(cls, type):
        raise DeployError(f"'{path}' is {_a(type(cls).__name__)}, not a class", mark)
    if expect is not None:
        bases = expect if isinstance(expect, tuple) else (expect,)
        if not issubclass(cls, bases):
            raise DeployError(f"'{path}' is not {_a(_or([b.__name__ for b in bases]))} "
                              f"(it must derive from {_or([_qual(b) for b in bases])})", mark)
    return cls


def _or(words: list[str]) -> str:
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " or " + words[-1]


def _qual(cls: type) -> str:
    """``esair_std.Behavior`` for the public classes, else the class's full name."""
    import esair_std

    if getattr(esair_std, cls.__name__, None) is cls:
        return f"esair_std.{cls.__name__}"
    return f"{cls.__module__}.{cls.__qualname__}"


def _a(noun: str) -> str:
    return f"an {noun}" if noun[:1].lower() in "aeiou" else f"a {noun}"


def _import(module_name: str, base: Path | None, mark: Mark | None) -> ModuleType:
    if base is not None:
        folder, top = str(base), module_name.split(".")[0]
        if folder not in sys.path:
            sys.path.append(folder)             # its neighbours, after everything else
        here = base / top
        if here.with_suffix(".py").is_file() or (here / "__init__.py").is_file():
            _own.folders[top] = folder
            if _own not in sys.meta_path:
                sys.meta_path.insert(0, _own)
        _forget_if_elsewhere(top, base)
    try:
        return importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        if exc.name and (module_name == exc.name or module_name.startswith(exc.name + ".")):
            hint = _module_hint(exc.name, base)
            raise DeployError(f"no module named {quote(exc.name)}{hint}; looked in the "
                              "deployment's folder, then sys.path", mark) from None
        raise DeployError(_failed(module_name, exc), mark) from None
    except (Exception, SystemExit) as exc:  # noqa: BLE001 - user code may raise anything
        raise DeployError(_failed(module_name, exc), mark) from None


def _forget_if_elsewhere(top: str, base: Path) -> None:
    """If ``top`` is in the folder but was imported from elsewhere, import it afresh."""
    here = base / top
    if not (here.with_suffix(".py").is_file() or (here / "__init__.py").is_file()):
        return
    loaded = sys.modules.get(top)
    origin = getattr(loaded, "__file__", None)
    if loaded is None or (origin and Path(origin).resolve().is_relative_to(base)):
        return
    for name in [n for n in sys.modules if n == top or n.startswith(top + ".")]:
        del sys.modules[name]


def _module_hint(missing: str, base: Path | None) -> str:
    import difflib
    import pkgutil
    parent, _, leaf = missing.rpartition(".")
    names: list[str] = []
    if parent:
        pkg = sys.modules.get(parent)
        if pkg is not None and hasattr(pkg, "__path__"):
            names = [m.name for m in pkgutil.iter_modules(pkg.__path__)]
    elif base is not None and base.is_dir():
        names = [m.name for m in pkgutil.iter_modules([str(base)])]
    close = difflib.get_close_matches(leaf, names, n=1, cutoff=0.6)
    return f" (did you mean '{parent + '.' if parent else ''}{close[0]}'?)" if close else ""


def _failed(module_name: str, exc: BaseException) -> str:
    """``importing module 'lab' failed at lab.py:3: ZeroDivisionError: division by zero``."""
    where = ""
    if isinstance(exc, SyntaxError) and exc.filename:
        where = f" at {_show_path(exc.filename)}:{exc.lineno}"
        text = f"SyntaxError: {exc.msg}"
    else:
        import traceback
        frames = [f for f in traceback.extract_tb(exc.__traceback__)
                  if not f.filename.startswith("<frozen")]
        if frames:
            where = f" at {_show_path(frames[-1].filename)}:{frames[-1].lineno}"
        text = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
    return f"importing module {quote(module_name)} failed{where}: {' '.join(text.split())}"


def _show_path(filename: str) -> str:
    rel = os.path.relpath(filename)
    return filename if rel.startswith("..") else rel


def component_class(class_path: str, base_dir: str | None, where: str = "",
                    kind: str | None = None) -> type:
    """The runtime's :func:`load_class`: ``class_path`` from ``base_dir`` first, then
    sys.path; every failure is a ComponentError, after ``where`` (the entry's
    file:line:col, if any). A ``behavior`` or ``reaction`` ``kind`` must derive from
    esair_std's Behavior or Reaction."""
    try:
        cls = load_class(class_path, base_dir)
    except DeployError as exc:
        raise ComponentError(f"{where}: {exc.message}" if where else exc.message) from None
    if kind in ("behavior", "reaction"):
        from .behavior import Behavior
        from .reaction import Reaction
        want = Behavior if kind == "behavior" else Reaction
        if not issubclass(cls, want):
            raise ComponentError(f"{class_path} is not a {want.__name__}")
    return cls


def quote(name: object) -> str:
    """As esair_min.config.schema_errors.quote, without importing pydantic."""
    text = str(name)
    return f"'{text}'" if text.isprintable() else repr(text)
