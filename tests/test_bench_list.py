"""bench/README.md lists every bench with what it measures, as ``python -m bench`` says:
a bench added or renamed without the list fails here."""

import ast
from pathlib import Path

from bench.__main__ import benches

ROOT = Path(__file__).resolve().parents[1]


def test_the_readme_lists_every_bench_as_python_m_bench_does():
    rows = [line for line in (ROOT / "bench" / "README.md").read_text().splitlines()
            if line.startswith("| `bench/")]
    listed = [row.split("`")[1].removeprefix("bench/") for row in rows]
    assert listed == [name for name, _ in benches()]
    assert all(what for _, what in benches())              # each says what it measures
    assert "std_comps.py" not in listed and len(listed) >= 20


def _imports(path: Path) -> set[str]:
    """Every module ``path`` imports (lazy imports inside functions included), and every
    ``module:Class`` path its strings name."""
    tree = ast.parse(path.read_text())
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            out.add(node.module)
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            out |= {m.split(":")[0] for m in node.value.split() if ":" in m and "." in m}
    return out


def test_no_bench_imports_the_tests_and_the_toolkit_no_bench():
    """The toolkit is the layer the benches and the tests share: the benches never
    reach into tests/, the toolkit imports neither a bench nor a test."""
    benches = list((ROOT / "bench").glob("*.py"))
    toolkit = list((ROOT / "bench" / "toolkit").glob("*.py"))
    assert len(benches) > 20 and len(toolkit) >= 5
    assert {p.name: sorted(m for m in _imports(p) if m.split(".")[0] == "tests")
            for p in benches + toolkit} == {p.name: [] for p in benches + toolkit}
    own = {p.stem for p in (ROOT / "bench").glob("*.py")}
    assert {p.name: sorted(m for m in _imports(p) if m.split(".")[0] in own | {"bench"}
                           and not m.startswith("bench.toolkit"))
            for p in toolkit} == {p.name: [] for p in toolkit}
    # the walk can fail: it finds what a bench imports and the class paths it deploys
    assert "bench.toolkit.netstd" in _imports(ROOT / "bench" / "std_net.py")
    assert "bench.toolkit.netcomps" in _imports(ROOT / "bench" / "std_net_lost.py")
