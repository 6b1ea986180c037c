"""Running a command that ends in ``esair monitor`` (``esair run``) until it monitors."""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path
from typing import Mapping


def run_until_monitoring(args: list[str], env: Mapping[str, str],
                         cwd: Path | None = None) -> tuple[int, str, str]:
    """``esair ARGS`` until its monitor's banner (it then takes Ctrl-C), then SIGINT:
    (status, stdout, stderr)."""
    proc = subprocess.Popen([sys.executable, "-m", "esair_min.cli", *args], env=dict(env),
                            text=True, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, cwd=cwd)
    assert proc.stderr is not None
    lines = []
    try:
        for line in proc.stderr:
            lines.append(line)
            if line.startswith("monitoring "):
                break
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=60)
    finally:                         # a failed run leaves no monitor behind
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    return proc.returncode, out, "".join(lines) + err
