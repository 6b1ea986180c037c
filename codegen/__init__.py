"""The firmware generator: a validated robot model in, one C source tree per board out.

Public API: :func:`generate_robot` (used by ``esair generate``). Modules, one concern each:
``filters`` (Jinja2 filters), ``timing`` (port numbers not in esair_min.model.hardware),
``context`` (the template context of each board, all numbers computed here),
``render`` (templates to text), ``writer`` (write-if-changed), ``generate`` (the whole).
"""

from .generate import GenerateResult, generate_robot, render_robot

__all__ = ["GenerateResult", "generate_robot", "render_robot"]
