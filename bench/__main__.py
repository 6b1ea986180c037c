"""``python -m bench``: the benchmarks, each with what it measures (its docstring's first
sentence) and how to run it; bench/README.md is the same list."""

from __future__ import annotations

import ast
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent


def benches() -> list[tuple[str, str]]:
    """(file name, what it measures) of every bench, in name order; the components
    modules the benches deploy (``*_comps.py``) are not benches, nor is what they share
    (the ``toolkit`` package)."""
    out = []
    for path in sorted(HERE.glob("*.py")):
        if path.name.startswith("_") or path.stem.endswith("_comps"):
            continue
        doc = ast.get_docstring(ast.parse(path.read_text())) or ""
        first = " ".join(doc.split("\n\n")[0].split())
        out.append((path.name, first))
    return out


def main() -> int:
    for name, what in benches():
        print(f"python bench/{name}\n    {what}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
