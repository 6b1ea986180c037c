"""Every test, bench, script or docs file that the docs, the scripts and the package
sources name exists (the tests moved into tests/min, tests/std, tests/net and
tests/support once; the docs kept the old paths, and scripts/mutation_c.py ran pytest on
files that were gone). A user follows these paths: a stale one is a broken link."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: a repository path as the docs write it: tests/min/test_x.py, bench/std_goals.py, docs/img/a.png
PATH = re.compile(r"(?<![\w/.-])((?:tests|bench|scripts|docs)/[\w./-]*\w\.(?:py|md|sh|txt|yaml|png))\b")


def sources() -> list[Path]:
    found = [ROOT / "README.md", ROOT / "pyproject.toml", ROOT / ".ci" / "run"]
    found += sorted((ROOT / "docs").glob("*.md")) + sorted((ROOT / "boards").glob("*/README.md"))
    found += sorted((ROOT / "scripts").glob("*")) + sorted((ROOT / "bench").glob("*.py"))
    for package in ("esair_min", "esair_std", "codegen"):
        found += sorted((ROOT / package).rglob("*.py"))
    return [p for p in found if p.is_file()]


def test_the_sources_are_found():
    names = {p.relative_to(ROOT).as_posix() for p in sources()}
    assert {"README.md", "docs/std.md", "scripts/mutation_c.py", "bench/std_goals.py",
            "esair_std/transport/security_config.py"} <= names


def test_every_named_path_exists():
    missing = []
    for src in sources():
        for n, line in enumerate(src.read_text(errors="replace").splitlines(), 1):
            missing += [f"{src.relative_to(ROOT)}:{n}: {m}" for m in PATH.findall(line)
                        if not (ROOT / m).exists()]
    assert missing == []
