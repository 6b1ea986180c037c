"""``esair std run ... --hmi`` (and ``--foxglove``): the HMI (the Foxglove server) as a
child process of the runtime's command (its own process, as on the remote center's
computer), ended with it."""

from __future__ import annotations

import os
import select
import signal
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import IO

from ..errors import StdError

START_TIMEOUT_S = 30.0


def _die_with_parent() -> None:
    try:
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM)   # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


def _end(proc: subprocess.Popen[bytes]) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=5)


class HmiChild:
    def __init__(self, endpoint: str, listen: str, root: Path | None = None,
                 insecure: bool = False, command: str = "hmi"):
        self.endpoint, self.listen, self.insecure = endpoint, listen, insecure
        self.command = command              # "hmi" or "foxglove": the same life cycle
        self.root = root or Path(__file__).resolve().parents[2]   # the tree it runs from
        self.proc: subprocess.Popen[bytes] | None = None
        self.url = ""
        self._errors: IO[bytes] | None = None

    def start(self) -> str:
        env = dict(os.environ)
        env["PYTHONPATH"] = str(self.root) + os.pathsep + env.get("PYTHONPATH", "")
        # not a pipe: nobody has to drain it; closed in stop()
        errors = self._errors = tempfile.TemporaryFile()  # noqa: SIM115
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "esair_min.cli", "std", self.command, "-e", self.endpoint,
             "--listen", self.listen, *(["--insecure"] if self.insecure else [])],
            stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=errors, env=env,
            preexec_fn=_die_with_parent)
        assert self.proc.stdout is not None
        ready, _, _ = select.select([self.proc.stdout], [], [], START_TIMEOUT_S)
        line = self.proc.stdout.readline().decode(errors="replace").strip() if ready else ""
        if not line.startswith(("http://", "https://", "ws://", "wss://")):
            _end(self.proc)                       # its last words are complete
            errors.seek(0)
            err = errors.read().decode(errors="replace").strip().splitlines()
            self.stop()
            what = "the HMI" if self.command == "hmi" else f"esair std {self.command}"
            raise StdError(f"{what} did not start: {err[-1] if err else 'no URL printed'}")
        self.url = line
        return line

    def stop(self) -> None:
        proc, self.proc = self.proc, None
        if proc is None:
            return
        _end(proc)
        for f in (proc.stdout, self._errors):
            if f is not None:
                f.close()
        self._errors = None
