"""The firmware generator: a validated robot model in, one C source tree per board out.

Public API: :func:`generate_robot` (used by ``esair generate``). Modules, one concern each:
``filters`` (Jinja2 filters), ``timing`` (port numbers not in esair_min.model.hardware),
``context`` (the template context of each board, all numbers computed here),
``render`` (templates to text), ``writer`` (write-if-changed), ``generate`` (the whole),
``buildid`` (the firmware's build id).

The API is imported when first used: an emulator that only asks the build id
(buildid.py, kept on disk) does not import Jinja2 and the templates' machinery.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .generate import GenerateResult, generate_robot, render_robot

__all__ = ["GenerateResult", "generate_robot", "render_robot"]


def __getattr__(name: str) -> Any:
    if name in __all__:
        from . import generate
        return getattr(generate, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
