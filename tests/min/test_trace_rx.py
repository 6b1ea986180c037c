"""``esair emulate --trace-rx``: the trace also holds each line the robot received, an
``RX`` line written before the line's reply (docs/trace-format.md); without ``--trace``
it is refused."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def emulate(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "esair_min.cli", "emulate", "papaman", *args],
                          capture_output=True, text=True, timeout=120, cwd=ROOT)


def test_rx_lines_come_before_their_replies(tmp_path):
    trace = tmp_path / "t.txt"
    r = emulate("--run", "0.2", "--send", "x", "--send", "v", "--trace", str(trace),
                "--trace-rx")
    assert r.returncode == 0, r.stderr
    lines = [ln for ln in trace.read_text().splitlines() if ln.startswith(("RX ", "TX "))]
    x, v = lines.index("RX 780D"), lines.index("RX 760D")
    assert lines[x + 1] == "TX 4F4B0D0A"                      # OK, after the x
    assert lines[v + 1].startswith("TX 4F4B2065736169722D6D696E2F31")   # OK esair-min/1
    plain = tmp_path / "plain.txt"
    assert emulate("--run", "0.2", "--send", "x", "--trace", str(plain)).returncode == 0
    assert not [ln for ln in plain.read_text().splitlines() if ln.startswith("RX ")]


def test_trace_rx_without_a_trace_is_refused():
    r = emulate("--run", "0.1", "--trace-rx")
    assert (r.returncode, r.stderr) == (1, "error: --trace-rx adds to the trace: give "
                                           "--trace FILE too\n")
