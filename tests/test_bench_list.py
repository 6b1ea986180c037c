"""bench/README.md lists every bench with what it measures, as ``python -m bench`` says:
a bench added or renamed without the list fails here."""

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
