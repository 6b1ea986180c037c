"""``make -B TARGET`` in a generated board folder, the one way every MCU's build runs
(esair_min/pic/build.py: SDCC; esair_min/avr/build.py: avr-gcc): every file compiled
again so every warning is seen, and any warning is a failure."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

from esair_min.errors import EsairError

_WARNING_RE = re.compile(r"warning", re.I)


def tail(text: str, lines: int = 30) -> str:
    return "\n".join(text.rstrip().splitlines()[-lines:])


def make_board(folder: Path, target: str, what: str, error: type[EsairError],
               make_vars: tuple[str, ...] = (), timeout: float = 300.0) -> str:
    """Run ``make -B target`` (``what``: "PIC", "AVR", for the messages); its output, or
    ``error`` when make cannot run, fails, or any tool prints a warning (lines shown)."""
    cmd = ["make", "-B", "--no-print-directory", "-C", str(folder), target, *make_vars]
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        raise error(f"{folder}: make {target} took more than {timeout:g} s") from None
    except OSError as exc:
        raise error(f"cannot run make: {exc.strerror}") from None
    out = proc.stdout + proc.stderr
    if proc.returncode != 0:
        raise error(f"{folder}: make {target} failed:\n{tail(out)}")
    warnings = [line for line in out.splitlines() if _WARNING_RE.search(line)]
    if warnings:
        raise error(f"{folder}: the {what} build printed {len(warnings)} warning(s):\n"
                    + "\n".join(warnings[:20]))
    return out
