"""The runtime's side of process mode's fork server (hosts/zygote.py): agent processes
forked from one process that imported the agent's code once, sharing those pages.

Each agent stays the runtime's own child (the runtime is a child subreaper while it
asks, so the zygote's grandchild is re-parented to it): it is waited for, killed by pid
and its exit status read as for a process started with Popen. When the fork server
cannot be used (it failed to start or died, the platform lacks a piece, the children's
start-up environment differs from its own, or ``ESAIR_STD_FORK=0``), ``spawn`` returns
None and the agent is started as a fresh interpreter instead.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from typing import TypedDict

log = logging.getLogger("esair_std.process")
READY_TIMEOUT = 30.0     # its imports on a loaded, capped computer
ANSWER_TIMEOUT = 10.0
PAD = 32768              # room for an agent's command line (its spec included)
PR_SET_CHILD_SUBREAPER = 36
# what the interpreter reads once, at its start: a child's must equal the zygote's
STARTUP = ("PYTHONPATH", "PYTHONHOME", "MALLOC_ARENA_MAX", "PYTHONMALLOC",
           "PYTHONHASHSEED", "PYTHONOPTIMIZE", "PYTHONDONTWRITEBYTECODE")
_reaper = threading.Lock()        # one spawn at a time sets and clears the subreaper


def _subreaper(on: bool) -> None:
    import ctypes
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.prctl(PR_SET_CHILD_SUBREAPER, int(on), 0, 0, 0) != 0:
        raise OSError(ctypes.get_errno(), "prctl(PR_SET_CHILD_SUBREAPER)")



class _Answer(TypedDict, total=False):
    """The fork server's word (hosts/zygote.py): its readiness, a forked agent's pid, or
    why it could not fork."""

    pid: int
    error: str

class Forked:
    """An agent forked by the zygote: what the runtime uses of a ``subprocess.Popen``
    (pid, stdin, poll, wait, kill), for a child of its own it did not exec."""

    def __init__(self, pid: int, stdin_fd: int, args: list[str]):
        self.pid = pid
        self.args = args
        self.stdin = os.fdopen(stdin_fd, "wb")
        self.returncode: int | None = None
        self._lock = threading.Lock()

    def poll(self) -> int | None:
        with self._lock:
            if self.returncode is None:
                try:
                    pid, status = os.waitpid(self.pid, os.WNOHANG)
                except ChildProcessError:        # reaped elsewhere: its status is gone
                    self.returncode = -1
                    return self.returncode
                if pid:
                    self.returncode = os.waitstatus_to_exitcode(status)
            return self.returncode

    def wait(self, timeout: float | None = None) -> int:
        deadline = None if timeout is None else time.monotonic() + timeout
        delay = 0.001
        while (code := self.poll()) is None:
            if deadline is not None and time.monotonic() >= deadline:
                raise subprocess.TimeoutExpired(self.args, timeout or 0.0)
            time.sleep(delay)
            delay = min(delay * 2, 0.05)
        return code

    def kill(self) -> None:
        with self._lock:
            if self.returncode is None:          # not reaped: the pid is still its own
                with contextlib.suppress(ProcessLookupError):
                    os.kill(self.pid, signal.SIGKILL)


class ForkServer:
    """One zygote per runtime, started with the children's start-up environment."""

    def __init__(self, env: dict[str, str]):
        self.startup = {k: env.get(k) for k in STARTUP}
        self.sock: socket.socket | None = None
        self.proc: subprocess.Popen[bytes] | None = None
        self.broken = ""
        if sys.platform != "linux" or env.get("ESAIR_STD_FORK", "1") == "0":
            self.broken = "not used"
            return
        ours, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        try:
            self.proc = subprocess.Popen(
                [sys.executable, "-P", "-m", "esair_std.hosts.zygote", str(theirs.fileno()),
                 "-" * PAD], pass_fds=[theirs.fileno()], stdin=subprocess.DEVNULL, env=env)
        except OSError as exc:
            ours.close()
            self.broken = str(exc)
            return
        finally:
            theirs.close()
        self.sock = ours
        self.ready = False

    def spawn(self, argv: list[str], env: dict[str, str], args: list[str]) -> Forked | None:
        """The agent ``argv`` (agent_process's arguments) forked, or None: start it
        otherwise."""
        if self.broken or self.sock is None:
            return None
        if {k: env.get(k) for k in STARTUP} != self.startup:
            return None
        r, w = os.pipe()
        try:
            with _reaper:
                if not self.ready:
                    self._receive(READY_TIMEOUT)
                    self.ready = True
                _subreaper(True)
                try:
                    req = json.dumps({"argv": argv, "env": env, "cwd": os.getcwd()})
                    socket.send_fds(self.sock, [req.encode()], [r, 1, 2])
                    answer = self._receive(ANSWER_TIMEOUT)
                finally:
                    _subreaper(False)
            if "pid" not in answer:
                raise OSError(answer.get("error", "no pid"))
        except (OSError, ValueError, AttributeError) as exc:
            self.broken = str(exc) or type(exc).__name__
            log.warning("the fork server failed (%s): agents start as new interpreters",
                        self.broken)
            os.close(w)
            return None
        finally:
            os.close(r)
        return Forked(int(answer["pid"]), w, args)

    def _receive(self, timeout: float) -> _Answer:
        assert self.sock is not None
        self.sock.settimeout(timeout)
        msg = self.sock.recv(65536)
        if not msg:
            raise OSError("the fork server exited")
        answer: _Answer = json.loads(msg)
        return answer

    def close(self) -> None:
        if self.sock is not None:
            self.sock.close()            # the zygote reads its end closed and leaves
            self.sock = None
        if self.proc is not None:
            try:
                self.proc.wait(2.0)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
