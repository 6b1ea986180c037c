"""A deployment checked outside the robot side's process, then loaded as plain data.

:func:`checked_deployment` is ``esair std run``'s: the cache first (cache.py: every
file the deployment was made from still the same, byte for byte); else a child forked
now — before any thread or Zenoh session exists in this process — imports pydantic,
checks the deployment as ``esair std check`` does and hands back its plain JSON
through a pipe, then exits, taking pydantic's memory with it. None when it cannot be
made plain (a problem in the deployment, a security section, no fork): the caller
then loads it in its own process, which gives the same error at the same file:line.
"""

from __future__ import annotations

import gc
import json
import os
import sys
import threading
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping

from . import cache
from .plain import PlainDeployment

if TYPE_CHECKING:  # pragma: no cover
    from esair_min.config.yamlload import Document

#: Why the last call returned what it did ("cache", "checked", or why not plain): for
#: tests, never for decisions.
last = {"how": ""}


def checked_deployment(path: str | Path, overrides: Mapping[str, object],
                       edit: Callable[[Document], None] | None = None,
                       ) -> PlainDeployment | None:
    """The deployment at ``path`` (with the command line's ``overrides``, which
    ``edit`` applies to the document read) checked and plain, or None (see the
    module docstring)."""
    key = cache.key(path, overrides)
    hit = cache.read(key)
    if hit is not None:
        last["how"] = "cache"
        return hit
    got = _in_child(path, edit)
    if not isinstance(got, dict):
        last["how"] = str(got)
        return None
    try:
        plain = PlainDeployment.from_json(got["deployment"])
    except (ValueError, KeyError, TypeError):
        last["how"] = "the checking child's answer is not a plain deployment"
        return None
    cache.write(key, got["deployment"], got.get("inputs", {}))
    last["how"] = "checked"
    return plain


def _in_child(path: str | Path, edit: Callable[[Document], None] | None) -> object:
    """The child's answer ({"deployment", "inputs"}), or why there is none (a str)."""
    if not hasattr(os, "fork") or threading.active_count() > 1:
        return "not forked: threads run here already"
    try:
        r, w = os.pipe()
        pid = os.fork()
    except OSError as exc:
        return f"not forked: {exc}"
    if pid == 0:                                  # the child: check, answer, leave
        gc.disable()            # it lives for one check: pydantic's import makes many
        os.close(r)             # objects and cycles the exit frees anyway
        code = 0
        try:
            answer: Any = _check(path, edit)
        except BaseException as exc:  # noqa: BLE001 - the parent checks again and says it
            answer, code = f"{type(exc).__name__}: {exc}", 1
        try:
            with os.fdopen(w, "w", encoding="utf-8") as f:
                f.write(json.dumps(answer))     # dumps: C's encoder (dump's is Python's)
        finally:
            os._exit(code)                        # no atexit, no flush of the parent's buffers
    os.close(w)
    with os.fdopen(r, encoding="utf-8") as f:
        text = f.read()
    os.waitpid(pid, 0)
    try:
        return json.loads(text)
    except ValueError:
        return "the checking child gave no answer"


def _check(path: str | Path, edit: Callable[[Document], None] | None) -> object:
    """In the child: the plain deployment and the hashes of the files it came from."""
    # ESAIR's own check, not the user's validation: no pydantic plugins, which pydantic
    # looks for by reading every installed package's entry points (unless told which)
    if "PYDANTIC_DISABLE_PLUGINS" not in os.environ:
        os.environ["PYDANTIC_DISABLE_PLUGINS"] = "__all__"
        _no_plugin_loader()
    _pydantic_without_asyncio()
    from ..deploy.compile import compile_deployment
    made = compile_deployment(path, edit)
    if made is None:
        return "not plain: the deployment has a security section"
    plain, inputs = made
    return {"deployment": plain, "inputs": cache.hashes(inputs)}


def _pydantic_without_asyncio() -> None:
    """Import pydantic without all of asyncio: its import marks its deprecated methods
    with ``typing_extensions.deprecated``, which imports ``asyncio.coroutines`` (and so
    the whole package, ssl included: about a sixth of pydantic's import) only to ask
    whether each is a coroutine function. In the checking child, which imports nothing
    of asyncio before and exits after one check, that question is answered as Python
    3.11's asyncio does, by a stand-in removed right after; a later ``import asyncio``
    gets the real one."""
    if "asyncio" in sys.modules or "pydantic.main" in sys.modules:
        import pydantic.main  # already imported, or asyncio is (nothing to spare)
        return
    import inspect
    import types
    marker = object()
    pkg, coroutines = types.ModuleType("asyncio"), types.ModuleType("asyncio.coroutines")
    vars(coroutines).update(_is_coroutine=marker, iscoroutinefunction=lambda f: (
        inspect.iscoroutinefunction(f) or getattr(f, "_is_coroutine", None) is marker))
    vars(pkg).update(coroutines=coroutines)
    stand_ins = {"asyncio": pkg, "asyncio.coroutines": coroutines}
    sys.modules.update(stand_ins)
    try:
        import pydantic.main  # noqa: F401
    finally:
        for name, module in stand_ins.items():
            if sys.modules.get(name) is module:
                del sys.modules[name]


def _no_plugin_loader() -> None:
    """With its plugins off, pydantic's plugin loader answers "none" to the question it
    is asked at each validator pydantic builds, but its module imports
    ``importlib.metadata`` (email and csv with it: about 3 % of a start's instructions)
    first. In the checking child, its one function, answering as it does with plugins
    off, stands in for it (should pydantic ask it for more, the check fails in the child
    and the runtime's process checks the deployment itself: slower, not wrong)."""
    import types
    name = "pydantic.plugin._loader"
    if name not in sys.modules:
        loader = types.ModuleType(name)
        vars(loader).update(get_plugins=lambda: ())
        sys.modules[name] = loader
