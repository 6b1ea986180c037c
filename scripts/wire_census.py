"""Counts, in ESAIR STD's sources, what issue 25.1 ("STD's wire in one place") names:

- error replies built: dict displays holding both an "error" and a "type" key;
- error maps: dicts from a type's name to an exception class (a decoder's table);
- verb chains: ``op == "..."`` / ``verb == "..."`` comparisons (if/elif dispatch);
- Any collaborators: parameters and attributes of a collaborating object (the runtime,
  a host, a port, a supervisor, a mode, a server...) annotated ``Any``;
- private reaches: ``obj._name`` where ``obj`` is not ``self``/``cls``.

    python scripts/wire_census.py [ROOT]     # ROOT: a checkout (default: this one)
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

COLLABORATORS = {"rt", "runtime", "host", "port", "_port", "server", "mode", "bs", "rs",
                 "sc", "ac", "center", "bus", "session", "handle", "driver", "deployment",
                 "_operator", "operator", "supervisor"}
EXCEPTIONS = ("Error", "Refused", "Lost")


def _is_any(ann: ast.expr | None) -> bool:
    if ann is None:
        return False
    if isinstance(ann, ast.Name):
        return ann.id == "Any"
    if isinstance(ann, ast.Constant) and isinstance(ann.value, str):
        return ann.value.replace(" ", "") in ("Any", "Any|None")
    if isinstance(ann, ast.BinOp):              # Any | None
        return _is_any(ann.left) or _is_any(ann.right)
    return False


def census(root: Path) -> dict[str, list[str]]:
    out: dict[str, list[str]] = {k: [] for k in (
        "error replies built", "error maps", "verb chains", "Any collaborators",
        "private reaches")}
    for path in sorted((root / "esair_std").rglob("*.py")):
        rel = path.relative_to(root)
        tree = ast.parse(path.read_text(), str(rel))
        for node in ast.walk(tree):
            where = f"{rel}:{getattr(node, 'lineno', 0)}"
            if isinstance(node, ast.Dict):
                names = {k.value for k in node.keys if isinstance(k, ast.Constant)}
                if {"error", "type"} <= names:
                    out["error replies built"].append(where)
                vals = node.values
                if (vals and all(isinstance(k, ast.Constant) and isinstance(k.value, str)
                                 for k in node.keys)
                        and all(isinstance(v, ast.Name) and v.id.endswith(EXCEPTIONS)
                                for v in vals)):
                    out["error maps"].append(where)
            elif isinstance(node, ast.Compare) and isinstance(node.left, ast.Name):
                if (node.left.id in ("op", "verb") and isinstance(node.ops[0], ast.Eq)
                        and isinstance(node.comparators[0], ast.Constant)):
                    out["verb chains"].append(where)
            elif isinstance(node, ast.arg) and node.arg in COLLABORATORS:
                if _is_any(node.annotation):
                    out["Any collaborators"].append(f"{where} {node.arg}")
            elif isinstance(node, ast.AnnAssign) and _is_any(node.annotation):
                t = node.target
                name = t.attr if isinstance(t, ast.Attribute) else getattr(t, "id", "")
                if name in COLLABORATORS:
                    out["Any collaborators"].append(f"{where} {name}")
            elif (isinstance(node, ast.Attribute) and node.attr.startswith("_")
                  and not node.attr.startswith("__")
                  and not (isinstance(node.value, ast.Name)
                           and node.value.id in ("self", "cls", "os", "sys"))):
                out["private reaches"].append(f"{where} .{node.attr}")
    return out


def main() -> None:
    root = Path(sys.argv[1] if len(sys.argv) > 1 else Path(__file__).resolve().parent.parent)
    for what, found in census(root).items():
        print(f"{what}: {len(found)}")
        for f in found:
            print(f"    {f}")


if __name__ == "__main__":
    main()
