"""bench/papaman_std.py removes its temporary folders (``esair-bench-*``): after a run,
and when Ctrl-C stops it mid-run. The bench runs as a user runs it, in a child process,
with TMPDIR pointing at a folder of the test's own."""

from __future__ import annotations

import pytest

import os
import signal
import subprocess
import sys
from pathlib import Path

from tests.support.std import ROOT, wait_for

pytestmark = pytest.mark.slow

BENCH = ROOT / "bench" / "papaman_std.py"


def _as_a_terminal_starts_it() -> None:
    # A program started in the background of a script (`pytest &`) inherits SIGINT
    # ignored, and Python then keeps it ignored: Ctrl-C would reach nothing. A terminal
    # starts the bench with SIGINT at its default.
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def bench(tmp: Path, n: int) -> subprocess.Popen:
    """One figure 1 run (thread mode, full duplex, feet not polled) of ``n`` commands."""
    env = dict(os.environ, TMPDIR=str(tmp))
    return subprocess.Popen([sys.executable, str(BENCH), "--one", "thread:1:0", "--n", str(n)],
                            cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, preexec_fn=_as_a_terminal_starts_it)


def test_a_run_leaves_no_bench_folder(tmp_path):
    proc = bench(tmp_path, 3)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    assert out.startswith("{") and '"lat": [' in out
    assert sorted(p.name for p in tmp_path.glob("esair-bench-*")) == []


def test_ctrl_c_mid_run_leaves_no_bench_folder(tmp_path):
    proc = bench(tmp_path, 100_000)               # ~1 hour of commands: stopped long before
    try:
        # mid-run: the emulated robot's trace is being written in the bench's folder
        [folder] = wait_for(lambda: [p for p in tmp_path.glob("esair-bench-*")
                                     if (p / "trace.txt").exists()], timeout=60,
                            what="the bench's folder with its trace")
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate(timeout=10)
    assert proc.returncode != 0 and "KeyboardInterrupt" in err, err
    assert not folder.exists()
    assert sorted(p.name for p in tmp_path.glob("esair-bench-*")) == []
