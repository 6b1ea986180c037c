"""The emulated robot as a child process behind a pty, at a stable path.

``esair emulate ROBOT --pty`` prints the pty it serves on its first line. A pty's name
changes each time the emulator starts, as a USB serial adapter's may when it is plugged
in again; :class:`EmulatedRobot` keeps a symbolic link (``port``) pointing at the
current pty, as udev does for a real adapter (``/dev/serial/by-id/...``). The link is
removed while no emulator runs, so a driver reopening ``port`` fails until the robot is
back. ``kill()`` (SIGKILL: the robot "pulled") and ``start()`` again are what the fault
tests do; under ``esair std run`` (``port: emulate``) the ``MinLink`` driver calls
``start()`` in ``open()``, again only under its ``emulate: {restart: ...}`` policy
after the child exited, and ``stop()`` (the child ended for good) in ``close()``. The
child gets SIGTERM if the thread that started it ends first (an agent process killed
outright).

Identity: every child boots with this object's ``instance`` (``--instance``), so the
robot answers ``v`` with ``id=instance`` across its restarts, and no other emulator
does. :meth:`wait_exit` reaps a child that exits by itself and
removes the port's link at once: the pty it served is no longer this robot's (the
kernel gives its number to the next program that opens a pty). :meth:`held` says why
the port must not be opened now, while no child of this object runs.
"""

from __future__ import annotations

import contextlib
import os
import secrets
import select
import signal
import subprocess
import sys
import tempfile
import threading
from pathlib import Path
from typing import IO, Sequence

from .link_errors import LinkError

START_TIMEOUT_S = 30.0


def _die_with_parent() -> None:
    """In the child before exec: SIGTERM when the thread that started it ends (Linux
    PR_SET_PDEATHSIG), so an agent process killed outright leaves no emulator behind."""
    try:
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM)   # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


class EmulatedRobot:
    """``esair emulate ROBOT --pty ARGS`` as a child process; ``port`` is a stable path."""

    def __init__(self, robot: str | Path, args: Sequence[str] = (),
                 port: str | Path | None = None, instance: str | None = None):
        self.robot = str(robot)
        self.args = tuple(args)
        self.instance = instance or secrets.token_hex(4)
        self.exit_status: int | None = None    # of the last child that exited by itself
        self._lock = threading.RLock()
        self._tmp: tempfile.TemporaryDirectory[str] | None = None
        if port is None:
            self._tmp = tempfile.TemporaryDirectory(prefix="esair-robot-")
            port = Path(self._tmp.name) / "robot.tty"
        self.port = str(port)
        self.pty: str | None = None
        self.proc: subprocess.Popen[bytes] | None = None
        self._errors: IO[bytes] | None = None
        self.starts = 0

    def start(self, extra: Sequence[str] = ()) -> str:
        """Start the emulator (``extra`` arguments for this start only); return ``port``."""
        with self._lock:
            if self.running:
                raise LinkError(f"the emulated robot on {self.port} is already running")
            if self.proc is not None:            # exited by itself, not reaped yet
                self._exited(self.proc)
        env = dict(os.environ)
        root = str(Path(__file__).resolve().parents[3])
        env["PYTHONPATH"] = root + os.pathsep + env.get("PYTHONPATH", "")
        cmd = [sys.executable, "-m", "esair_min.cli", "emulate", self.robot, "--pty",
               "--instance", self.instance, *self.args, *extra]
        errors = tempfile.TemporaryFile()  # noqa: SIM115  (kept with the process; not a pipe: nobody drains it)
        proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                stderr=errors, env=env, start_new_session=True,
                                preexec_fn=_die_with_parent)
        self.proc, self._errors = proc, errors
        assert proc.stdout is not None
        ready, _, _ = select.select([proc.stdout], [], [], START_TIMEOUT_S)
        line = proc.stdout.readline().decode(errors="replace").strip() if ready else ""
        if not line.startswith("/dev/"):
            self._errors = None                  # read here, before _reap closes it
            self._reap(signal.SIGKILL)
            errors.seek(0)
            err = errors.read().decode(errors="replace").strip()
            errors.close()
            raise LinkError(f"the emulator did not start ({' '.join(cmd[2:])}): "
                            f"{err.splitlines()[-1] if err else 'no pty path printed'}")
        with self._lock:
            if proc.poll() is not None:          # died before its port was linked
                self._exited(proc)
                raise LinkError(f"the emulator exited (status {proc.returncode}) right "
                                f"after it started")
            self.pty = line
            tmp = self.port + ".new"
            if os.path.lexists(tmp):
                os.unlink(tmp)
            os.symlink(line, tmp)
            os.replace(tmp, self.port)
            self.exit_status = None
        self.starts += 1
        return self.port

    @property
    def running(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    def held(self) -> str | None:
        """None while a child of this object serves the port; else why not to open it."""
        with self._lock:
            proc = self.proc
            if proc is not None and proc.poll() is None:
                return None
            if proc is not None:                 # exited, not yet seen by wait_exit
                self._exited(proc)
            if self.exit_status is not None:
                return f"emulator exited (status {self.exit_status})"
            return "emulator not running"

    def wait_exit(self) -> int | None:
        """Block until the current child ends; if it ended by itself (not by kill() or
        stop()), reap it, unlink the port and return its status; else None."""
        proc = self.proc
        if proc is None:
            return None
        code = proc.wait()
        with self._lock:
            if self.proc is not proc:            # kill() / stop(): not an exit of its own
                return None
            self._exited(proc)
            return code

    def _exited(self, proc: subprocess.Popen[bytes]) -> None:
        """(lock held) ``proc`` exited by itself: unlink the port first, then clean up."""
        self._unlink()
        self.exit_status = proc.returncode
        self.proc = None
        for f in (proc.stdout, self._errors):
            if f is not None:
                f.close()
        self._errors = None
        self.pty = None

    def play_scenario(self) -> None:
        """Play the emulator's scenario from its start now (SIGUSR1; started with
        ``--hold-scenario``, the scenario waits for this, not for boot)."""
        with self._lock:
            proc = self.proc
            if proc is None or proc.poll() is not None:
                raise LinkError(f"the emulated robot on {self.port} is not running: no "
                                "scenario to play")
            proc.send_signal(signal.SIGUSR1)

    def kill(self) -> None:
        """Pull the robot: SIGKILL the emulator and remove the port's link."""
        self._unlink()
        self._reap(signal.SIGKILL)

    def stop(self) -> None:
        """End the emulator (SIGTERM, then SIGKILL) and clean up."""
        self._unlink()
        self._reap(signal.SIGTERM)
        if self._tmp is not None:
            self._tmp.cleanup()
            self._tmp = None

    def __enter__(self) -> "EmulatedRobot":
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def _unlink(self) -> None:
        if os.path.islink(self.port):
            with contextlib.suppress(FileNotFoundError):     # two threads at once
                os.unlink(self.port)

    def _reap(self, sig: int) -> None:
        with self._lock:
            proc, self.proc = self.proc, None
        if proc is None:
            return
        if proc.poll() is None:
            proc.send_signal(sig)
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(timeout=10)
        for f in (proc.stdout, self._errors):
            if f is not None:
                f.close()
        self._errors = None
        self.pty = None
