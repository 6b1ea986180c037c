"""The board model's static view (what mypy checks against) names the same sections,
with the same item types, as the Board that pydantic builds from COMPONENTS at run time."""

import ast
import inspect

from esair_min.components import COMPONENTS
from esair_min.model import board


def _static_fields() -> dict[str, str]:
    tree = ast.parse(inspect.getsource(board))
    for node in ast.walk(tree):
        if isinstance(node, ast.ClassDef) and node.name == "Board":
            return {item.target.id: ast.unparse(item.annotation) for item in node.body
                    if isinstance(item, ast.AnnAssign) and isinstance(item.target, ast.Name)}
    raise AssertionError("no static Board class in esair_min/model/board.py")


def test_every_kind_has_its_field_in_the_static_view():
    want = {c.section: (f"tuple[{c.schema.__name__}, ...]" if c.many
                        else f"{c.schema.__name__} | None") for c in COMPONENTS}
    assert _static_fields() == want


def test_the_run_time_board_has_those_fields():
    core = set(board.BoardCore.model_fields)
    assert set(board.Board.model_fields) - core == set(_static_fields())
