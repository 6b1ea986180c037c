"""Generate the firmware of every board of a robot: one folder per board role."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from esair_min.components import COMPONENTS
from esair_min.errors import GenerateError
from esair_min.model.robot import Robot

from .context import board_context
from .render import render_board
from .writer import write_tree


@dataclass(frozen=True)
class GenerateResult:
    """What :func:`generate_robot` did (paths are under ``out_dir``)."""

    out_dir: Path
    boards: tuple[str, ...]
    written: tuple[Path, ...]
    unchanged: tuple[Path, ...]

    @property
    def files(self) -> tuple[Path, ...]:
        return tuple(sorted(self.written + self.unchanged))


def render_robot(robot: Robot) -> dict[str, str]:
    """``{"<role>/<path>": text}`` for every board of ``robot`` (nothing written)."""
    missing = sorted({k.kind for b in robot.boards for k in COMPONENTS
                      if not k.generated and k.items(b)})
    if missing:
        raise GenerateError(f"robot '{robot.name}': no firmware templates yet for the device "
                            f"kinds {', '.join(missing)}; 'esair check' validates the robot, "
                            "and their Python cores (esair_min.components) model it")
    files: dict[str, str] = {}
    for board in sorted(robot.boards, key=lambda b: b.role):
        for rel, text in render_board(board.role, board_context(robot, board.role)).items():
            files[f"{board.role}/{rel}"] = text
    return files


def generate_robot(robot: Robot, out_dir: Path, *, check: bool = True) -> GenerateResult:
    """Render every board and write the files whose content changed under ``out_dir``."""
    out_dir = Path(out_dir)
    files = render_robot(robot)
    result = write_tree(files, out_dir, check=check)
    boards = tuple(sorted(b.role for b in robot.boards))
    return GenerateResult(out_dir, boards, result.written, result.unchanged)
