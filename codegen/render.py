"""Templates to text: a Jinja2 environment (StrictUndefined, named filters only).

Every ``firmware_templates/<role>/**/*.j2`` file becomes one output file of that board
(the path without ``.j2``); ``firmware_templates/common/`` holds macros and includes
that are never output themselves.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import jinja2

from esair_min.errors import GenerateError
from esair_min.resources import templates_dir

from .filters import FILTERS
from .context import Context
from .ports import wanted_template


@lru_cache(maxsize=4)
def environment(root: str) -> jinja2.Environment:
    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(root),
        undefined=jinja2.StrictUndefined,
        keep_trailing_newline=True,
        trim_blocks=True,
        lstrip_blocks=True,
        autoescape=False,
    )
    env.filters.update(FILTERS)
    return env


def template_names(role: str, root: Path | None = None) -> list[str]:
    """The templates of a board role, sorted (stable output order)."""
    base = (root or templates_dir()) / role
    if not base.is_dir():
        raise GenerateError(f"no firmware templates for role '{role}' in {base.parent}")
    return sorted(p.relative_to(base.parent).as_posix() for p in base.rglob("*.j2"))


def render_board(role: str, ctx: Context, root: Path | None = None) -> dict[str, str]:
    """``{path inside the board folder: text}`` for every template of ``role``."""
    root = root or templates_dir()
    env = environment(str(root))
    out: dict[str, str] = {}
    part = ctx.get("part", "")
    for name in template_names(role, root):
        if not wanted_template(name, role, part):
            continue
        rel = name[len(role) + 1:-len(".j2")]
        try:
            text = env.get_template(name).render(**ctx, out_path=rel)
        except jinja2.UndefinedError as exc:
            raise GenerateError(f"template {name}: {exc.message}") from None
        except jinja2.TemplateError as exc:
            raise GenerateError(f"template {name}: {exc}") from None
        out[rel] = text if text.endswith("\n") else text + "\n"
    return out
