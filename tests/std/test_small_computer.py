"""bench/small_computer.py: the robot side in a capped control group (issue 37 item 1).

A short run (PAPA-MAN, thread mode, capped and uncapped) prints its figures, and leaves
nothing behind: no control group, no process (each started with a marker in its
environment, looked for in every process's), no temporary folder."""

from __future__ import annotations

import json
import os
import secrets
import subprocess
import sys
from pathlib import Path

import pytest

from tests.support.std import ROOT

sys.path.insert(0, str(ROOT / "bench"))
import small_computer

CGROUPS = Path("/sys/fs/cgroup")


def _can_make_groups() -> bool:
    if os.geteuid() != 0:
        return False
    if small_computer.Cap.V2.exists():
        return os.access(CGROUPS, os.W_OK)
    return all(os.access(CGROUPS / h, os.W_OK) for h in ("cpu", "memory"))


pytestmark = [pytest.mark.pty, pytest.mark.slow,
              pytest.mark.skipif(not _can_make_groups(),
                                 reason="needs root and writable cgroup cpu/memory controllers")]


def _marked(marker: str) -> list[int]:
    out = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                if marker.encode() in (d / "environ").read_bytes():
                    out.append(int(d.name))
            except OSError:
                pass
    return out


def test_the_cap_is_set_and_removed():
    with small_computer.Cap(limit=True) as cap:
        if cap.v2:
            assert (cap.dirs[0] / "cpu.max").read_text().split() == ["25000", "100000"]
            assert int((cap.dirs[0] / "memory.max").read_text()) == 128 << 20
        else:
            assert int((cap.dirs[0] / "cpu.cfs_quota_us").read_text()) == 25000
            assert int((cap.dirs[0] / "cpu.cfs_period_us").read_text()) == 100000
            assert int((cap.dirs[1] / "memory.limit_in_bytes").read_text()) == 128 << 20
        child = subprocess.Popen(["sleep", "600"], preexec_fn=cap.join)
        assert cap.pids() == [child.pid]
    assert child.wait(10) == -9                 # what was left in the group was ended
    assert not any(d.exists() for d in cap.dirs)


def test_a_short_run_prints_its_figures_and_leaves_nothing(tmp_path):
    marker = f"ESAIR_SMALL_TEST={secrets.token_hex(6)}"
    key, value = marker.split("=")
    env = dict(os.environ, TMPDIR=str(tmp_path), PYTHONPATH=str(ROOT), **{key: value})
    out = subprocess.run([sys.executable, str(ROOT / "bench" / "small_computer.py"),
                          "--robots", "papaman", "--modes", "thread", "--window", "1",
                          "--settle", "0.5", "--n", "12", "--asks", "3"],
                         cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    assert "Raspberry Pi Zero 2 W" in out.stdout
    rows = json.loads(out.stdout.splitlines()[-1])["rows"]
    assert [r["capped"] for r in rows] == [True, False]
    for r in rows:
        assert "error" not in r, r
        assert r["cmd_n"] == 12 and r["cmd_errors"] == 0 and r["writes"] >= 12
        assert r["processes"] == 1 and r["rss_mb"] > 0 and r["pss_mb"] > 0
        assert r["samples"] > 0 and r["lost"] >= 0 and r["ready_s"] > 0
        assert r["ask_n"] == 6 and r["ask_missed"] == 0
        assert r["groups"] and not any(Path(d).exists() for d in r["groups"])
    assert _marked(marker) == []
    assert list(tmp_path.iterdir()) == []
