"""The import graph of ESAIR's own packages, read with ``ast`` (nothing is imported).

Every ``import``/``from ... import`` counts, at module level or inside a function (a
lazy import is still an arrow). An arrow from a module to the package that contains it
is left out (Python imports the parent first anyway) unless it takes a name the parent
defines, not a submodule."""

from __future__ import annotations

import ast
import functools
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = {"esair_min": ROOT / "esair_min", "esair_std": ROOT / "esair_std",
            "esair_min.codegen": ROOT / "codegen"}


def modules() -> dict[str, Path]:
    """Dotted name → file of every module of the packages (the codegen link is not
    followed: the generator is read from its own folder)."""
    found: dict[str, Path] = {}
    for prefix, folder in PACKAGES.items():
        for path in sorted(folder.rglob("*.py")):
            rel = path.relative_to(folder).with_suffix("")
            if "codegen" in rel.parts and prefix == "esair_min":
                continue
            if (prefix == "esair_std" and rel.parts[-1] != "__init__"
                    and any(p in ("examples", "fixtures") for p in rel.parts[:-1])):
                continue
            parts = [p for p in rel.parts if p != "__init__"]
            found[".".join([prefix, *parts])] = path
    return found


def _resolve(mod: str, is_pkg: bool, node: ast.ImportFrom) -> str:
    if not node.level:
        return node.module or ""
    base = mod.split(".") if is_pkg else mod.split(".")[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


@functools.cache
def graph() -> dict[str, set[str]]:
    """Module → the modules of ours it imports."""
    mods = modules()
    edges: dict[str, set[str]] = {m: set() for m in mods}
    for mod, path in mods.items():
        is_pkg = path.name == "__init__.py"
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = _resolve(mod, is_pkg, node)
                for a in node.names:
                    sub = f"{base}.{a.name}"
                    targets.append(sub if sub in mods else base)
            for t in targets:
                while t and t not in mods:
                    t = t.rpartition(".")[0]
                if not t or t == mod:
                    continue
                if mod.startswith(t + ".") and not _takes_name(node, t, mods):
                    continue
                edges[mod].add(t)
    return edges


def _takes_name(node: ast.AST, parent: str, mods: dict[str, Path]) -> bool:
    """Whether an import of ``parent`` from inside it takes a name the parent defines."""
    if not isinstance(node, ast.ImportFrom):
        return False
    return any(f"{parent}.{a.name}" not in mods for a in node.names)


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(edges[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return out
