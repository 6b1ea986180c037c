"""docs/std.md's "Your first behavior" runs as it is written (issue 34 item 5): its shell
blocks through bash with `esair` on the PATH, its Python block saved as the file it
names, its YAML block appended to the deployment; the behavior reads the feet and
commands the knee of the emulated PAPA-MAN. Both modes (process: `--mode process` added
to the run)."""

import os
import re
import stat
import subprocess
import sys

import pytest

from tests.support.std import MODES, ROOT

DOC = ROOT / "docs" / "std.md"


def section_blocks() -> list[tuple[str, str]]:
    """(language, text) of each fenced block of the section, in order."""
    text = DOC.read_text()
    start = text.index("## Your first behavior")
    end = text.index("\n## ", start + 1)
    return re.findall(r"```(\w+)\n(.*?)```", text[start:end], re.S)


def test_the_section_has_what_the_tutorial_needs():
    langs = [lang for lang, _ in section_blocks()]
    assert langs == ["sh", "python", "yaml", "sh"]


@pytest.mark.pty
@pytest.mark.parametrize("mode", MODES)
def test_the_first_behavior_runs_as_written(mode, tmp_path):
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    shim = bin_dir / "esair"
    shim.write_text(f'#!/bin/sh\nexec {sys.executable} -m esair_min.cli "$@"\n')
    shim.chmod(shim.stat().st_mode | stat.S_IXUSR)
    env = dict(os.environ, PATH=f"{bin_dir}:{os.environ['PATH']}", PYTHONPATH=str(ROOT))
    out = []
    for lang, block in section_blocks():
        if lang == "sh":
            if mode == "process":
                block = block.replace("esair std run mybot", "esair std run mybot --mode process")
            r = subprocess.run(["bash", "-euc", block], cwd=tmp_path, env=env,
                               capture_output=True, text=True, timeout=180)
            assert r.returncode == 0, f"{block}\n{r.stdout}\n{r.stderr}"
            out.append(r.stdout)
        elif lang == "python":
            (tmp_path / "mybot" / "knee.py").write_text(block)
        else:
            with open(tmp_path / "mybot" / "mybot.yaml", "a") as f:
                f.write(block)
    summary = {line.split()[0]: line.split() for line in out[-1].splitlines()
               if line.split()}
    assert "ok" in out[-1].splitlines()                       # esair std check mybot
    assert summary["knee"][1:3] == ["behavior", "running"], out[-1]
    assert int(summary["papaman.servo.l_knee"][5]) > 0, out[-1]   # COMMANDS it carried out
