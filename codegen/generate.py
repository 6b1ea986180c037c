"""Generate the firmware of every board of a robot: one folder per board role."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from esair_min.components import COMPONENTS
from esair_min.errors import GenerateError
from esair_min.model.board import Board
from esair_min.model.robot import Robot

from .buildid import central_build_id
from .context import board_context, central_context
from .drive import drive_context
from .omni_context import omni_central_context
from .render import render_board
from .writer import write_tree

#: Template folders whose context is not PAPA-MAN's role builders' (codegen/context.py).
EXTRA_BUILDERS = {"omni_central": omni_central_context, "drive": drive_context}


@dataclass(frozen=True)
class GenerateResult:
    """What :func:`generate_robot` did (paths are under ``out_dir``)."""

    out_dir: Path
    boards: tuple[str, ...]
    written: tuple[Path, ...]
    unchanged: tuple[Path, ...]
    skipped: tuple[str, ...] = ()     # boards not generated: "role (kinds without templates)"

    @property
    def files(self) -> tuple[Path, ...]:
        return tuple(sorted(self.written + self.unchanged))


def ungenerated(robot: Robot) -> dict[str, list[str]]:
    """``{board role: [kinds without C templates]}`` for the boards the generator skips."""
    out: dict[str, list[str]] = {}
    for b in robot.boards:
        kinds = sorted(k.kind for k in COMPONENTS if not k.generated and k.items(b))
        if kinds:
            out[b.role] = kinds
    return out


def template_folder(board: Board) -> str:
    """The folder of firmware_templates/ a board is made from."""
    return "omni_central" if board.role == "central" and board.base is not None else board.role


def render_robot(robot: Robot) -> dict[str, str]:
    """``{"<role>/<path>": text}`` for every board of ``robot`` that the generator has
    templates for (nothing written; :func:`ungenerated` names the others)."""
    skipped = ungenerated(robot)
    files: dict[str, str] = {}
    for board in sorted(robot.boards, key=lambda b: b.role):
        if board.role in skipped:
            continue
        folder = template_folder(board)
        builder = EXTRA_BUILDERS.get(folder)
        if builder:
            ctx = builder(robot)
        elif board.role == "central":   # the build id hashes the sources it goes into
            ctx = central_context(robot, central_build_id(robot))
        else:
            ctx = board_context(robot, board.role)
        for rel, text in render_board(folder, ctx).items():
            files[f"{board.role}/{rel}"] = text
    if not files:
        raise GenerateError(f"robot '{robot.name}': no firmware templates yet for the device "
                            f"kinds {', '.join(sorted({k for v in skipped.values() for k in v}))}")
    return files


def generate_robot(robot: Robot, out_dir: Path, *, check: bool = True) -> GenerateResult:
    """Render every board and write the files whose content changed under ``out_dir``."""
    out_dir = Path(out_dir)
    files = render_robot(robot)
    result = write_tree(files, out_dir, check=check)
    skipped = ungenerated(robot)
    boards = tuple(sorted(b.role for b in robot.boards if b.role not in skipped))
    return GenerateResult(out_dir, boards, result.written, result.unchanged,
                          tuple(f"{role} ({', '.join(kinds)})" for role, kinds in sorted(skipped.items())))
