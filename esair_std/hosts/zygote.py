"""Process mode's fork server ("zygote"): ``python -P -m esair_std.hosts.zygote FD PAD``.

It imports what every agent process imports (the agent, its hosts, the transport and
Zenoh's module) once, freezes that heap (gc.freeze: the collector of a child never
writes to it), then forks one agent process per request read from the runtime's socket
``FD``; the children share those pages copy-on-write instead of each importing its own.
No thread and no Zenoh session exists here (forking after threads is unsafe): each child
opens its own session, after the fork, in ``agent_process.main``.

A request (one datagram) is ``{"argv", "env", "cwd"}`` with the child's stdin, stdout
and stderr as passed descriptors. The zygote forks twice: the middle process exits at
once, so the agent is re-parented to the runtime (a child subreaper while it asks,
modes/forkserver.py) and the runtime waits for it, kills it by pid and reads its exit
status as for a process it started itself. The answer is ``{"pid": N}`` or
``{"error": "..."}``. The zygote leaves when the runtime's end of the socket closes.
``PAD`` only makes room in the command line: each agent writes its own there (``ps``,
and whoever looks for an agent by its command line, see what it is).
"""

from __future__ import annotations

import gc
import json
import os
import signal
import sys
from array import array
from typing import TypedDict

# the C module, not socket.py: an agent imports no more than it needs
import _socket

MAX_REQUEST = 1 << 20


def _preload() -> None:
    import zenoh  # noqa: F401 - imported here once, shared by every child

    from . import agent_process, behavior_host, resource_host  # noqa: F401
    from ..transport import session  # noqa: F401


def _set_cmdline(argv: list[str]) -> None:
    """Writes ``argv`` over this process's own command-line area (what
    /proc/PID/cmdline shows), cut to the area's length, the rest zeroed."""
    try:
        with open("/proc/self/stat", "rb") as f:
            fields = f.read().rsplit(b")", 1)[1].split()
        start, end = int(fields[45]), int(fields[46])      # arg_start, arg_end
        text = b"\0".join(a.encode() for a in argv)[:end - start - 1]
        with open("/proc/self/mem", "r+b", buffering=0) as mem:
            mem.seek(start)
            mem.write(text.ljust(end - start, b"\0"))
    except (OSError, IndexError, ValueError):
        pass                                               # cosmetic only


class _Request(TypedDict):
    """The runtime's request for one agent (modes/forkserver.py, spawn)."""

    argv: list[str]
    env: dict[str, str]
    cwd: str


def _child(sock: _socket.socket, req: _Request, fds: list[int]) -> None:
    """In the forked agent: its descriptors, folder, environment and command line, then
    the agent itself. Never returns."""
    code = 1
    try:
        sock.close()
        for i, fd in enumerate(fds[:3]):
            os.dup2(fd, i)
        for fd in fds:
            if fd > 2:
                os.close(fd)
        os.chdir(req["cwd"])
        os.environ.clear()
        os.environ.update(req["env"])
        signal.signal(signal.SIGCHLD, signal.SIG_DFL)
        _set_cmdline([sys.executable, "-P", "-m", "esair_std.hosts.agent_process",
                      *req["argv"]])
        from . import agent_process
        sys.argv = [agent_process.__file__, *req["argv"]]
        code = agent_process.main(req["argv"])
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 1
    except BaseException:  # noqa: BLE001 - said on stderr, as an interpreter would
        import traceback
        traceback.print_exc()
    finally:
        for f in (sys.stdout, sys.stderr):
            try:
                f.flush()
            except Exception:  # noqa: BLE001 - exiting anyway
                pass
        os._exit(code)


def _fork(sock: _socket.socket, req: _Request, fds: list[int]) -> int:
    """Forks the agent as a grandchild; its pid."""
    r, w = os.pipe()
    middle = os.fork()
    if middle == 0:
        try:
            os.close(r)
            pid = os.fork()
            if pid == 0:
                os.close(w)
                _child(sock, req, fds)
            os.write(w, str(pid).encode())
        finally:
            os._exit(0)
    os.close(w)
    with os.fdopen(r, "rb") as f:
        text = f.read()
    os.waitpid(middle, 0)
    return int(text)


def _receive(sock: _socket.socket) -> tuple[bytes, list[int]]:
    """One request and the descriptors passed with it (socket.recv_fds's way)."""
    fds = array("i")
    msg, ancillary, _flags, _addr = sock.recvmsg(MAX_REQUEST, _socket.CMSG_LEN(3 * fds.itemsize))
    for level, kind, data in ancillary:
        if level == _socket.SOL_SOCKET and kind == _socket.SCM_RIGHTS:
            fds.frombytes(data[:len(data) - len(data) % fds.itemsize])
    return msg, list(fds)


def serve(sock: _socket.socket) -> None:
    try:
        sock.send(b'{"ready": true}')
    except OSError:
        return                  # the runtime went away while this one started
    while True:
        try:
            msg, fds = _receive(sock)
        except OSError:
            return
        if not msg:
            return                                     # the runtime closed its end
        try:
            if len(os.listdir("/proc/self/task")) != 1:
                raise RuntimeError("the fork server has threads: it must not fork")
            answer: dict[str, int | str] = {"pid": _fork(sock, json.loads(msg), fds)}
        except Exception as exc:  # noqa: BLE001 - the runtime starts it otherwise
            answer = {"error": f"{type(exc).__name__}: {exc}"}
        finally:
            for fd in fds:
                os.close(fd)
        try:
            sock.send(json.dumps(answer).encode())
        except OSError:
            return              # the runtime went away while it forked (a stop while starting)


def main() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)      # the runtime ends its agents itself
    sock = _socket.socket(fileno=int(sys.argv[1]))
    _preload()
    gc.collect()
    gc.freeze()
    serve(sock)
    os._exit(0)


if __name__ == "__main__":
    main()
