"""STD test helpers (imported by the tests; the fixtures are in tests/std/conftest.py)."""

import os
import signal
import subprocess
import sys
import threading
from contextlib import contextmanager
from pathlib import Path

from bench.toolkit import free_endpoint, processes, wait_for  # noqa: F401  (the tests' too)

#: the checkout: child processes start here, so ``tests.support`` imports in them
ROOT = Path(__file__).resolve().parents[2]

MODES = ["thread", "process"]


def ask(ep: str, verb: str, body: dict | None = None, timeout: float = 5.0):
    """The ``ok`` value of the runtime's answer to control request ``verb`` on ``ep``
    (an error it answers is raised), asked from this process by the client ``esair std``
    uses (esair_std.cli.client); None when no runtime answers. For the waits and the
    checks that are not about the command line: ``esair std ls`` in a child process
    costs an interpreter's start (1-2 s on a loaded machine) per ask."""
    from esair_std.cli.client import Client
    from esair_std.errors import TransportError
    try:
        with Client(ep) as c:
            return c.call(verb, body, timeout)
    except TransportError:
        return None


def components(ep: str) -> list[dict]:
    """The runtime's component rows (``esair std ls --json``'s "components"), asked from
    this process (:func:`ask`); [] when no runtime answers."""
    return ask(ep, "ls", {"all": True}) or []


#: every component of the lab robot (esair_std/examples/lab/lab.yaml)
LAB = ("guard", "logger", "follow", "tuner", "keeper", "wave", "ticks", "arm", "bench")


def lab_started(ep: str, names=LAB) -> bool:
    """Every one of ``names`` is listed, running or ready, and the runtime no longer
    says it is starting. (A runtime answers while it starts, its list growing: "all
    listed are running" holds at its first resource.)"""
    state = {r["name"]: r["state"] for r in components(ep)}
    if not all(state.get(n) in ("running", "ready") for n in names):
        return False
    ping = ask(ep, "ping")
    return isinstance(ping, dict) and ping.get("starting") is False


def emulators_with(text: str) -> list[int]:
    """Pids of `esair emulate` processes whose command line holds ``text``."""
    return [pid for pid, _ppid, cmd in processes()
            if b"emulate" in cmd.split(b"\0") and text.encode() in cmd.split(b"\0")]


def agent_children() -> list[int]:
    """Agent processes whose parent is this test process."""
    return [pid for pid, ppid, cmd in processes()
            if ppid == os.getpid() and b"esair_std.hosts.agent_process" in cmd]


#: ``esair std`` verbs that only talk to a running robot or read a file: :func:`esair`
#: runs them in this process (``check`` only with ``--no-import``: its imports of a
#: deployment's modules stay in a child, no module cached from an earlier check)
IN_PROCESS = {"ls", "get", "put", "add", "remove", "add-resource", "remove-resource", "sample",
              "send", "configure", "reaction", "inspect", "stop", "release", "ping", "top",
              "schema", "new"}


def esair(*args: str, check: bool = True, cwd: str | Path = ROOT,
          stdin: str | None = None, env: dict | None = None) -> subprocess.CompletedProcess:
    """``esair std ARGS`` from ``cwd`` (the checkout by default; ``stdin``: its standard
    input; ``env``: variables set for it): the verbs of :data:`IN_PROCESS` run in this
    process (:func:`std_cli`), every other (``run``, ``agent``, ``hmi``...) in a child
    process."""
    here = Path(cwd).resolve() == Path.cwd().resolve()
    if here and args and (args[0] in IN_PROCESS or args[0] == "check" and "--no-import" in args):
        r = std_cli(*args, stdin=stdin, env=env)
    else:
        r = subprocess.run([sys.executable, "-m", "esair_min.cli", "std", *args],
                           capture_output=True, text=True, timeout=90, cwd=cwd, input=stdin,
                           env=dict(os.environ, COLUMNS="200", **(env or {})))
    if check and r.returncode != 0:
        raise AssertionError(f"esair std {' '.join(args)}: {r.returncode}\n{r.stderr}")
    return r


def std_cli(*args: str, stdin: str | None = None,
            env: dict | None = None) -> subprocess.CompletedProcess:
    """``esair std ARGS`` run in this process by the command line's own click entry point
    (what the ``esair`` program runs): the exit status, standard output and standard
    error apart, as a child's, without an interpreter's start. An exception no command
    turns into a status is raised: the user would see its traceback."""
    from click.testing import CliRunner

    from esair_min.cli import main
    r = CliRunner().invoke(main, ["std", *args], input=stdin,
                           env={"COLUMNS": "200", **(env or {})}, catch_exceptions=False,
                           prog_name="esair")
    return subprocess.CompletedProcess(["esair", "std", *args], r.exit_code, r.stdout, r.stderr)


@contextmanager
def std_run(deployment: str, mode: str, ep: str, deployed, what: str = "deployed"):
    """``esair std run DEPLOYMENT --mode MODE -e EP`` in a child process, yielded once
    ``deployed()`` holds; stopped with SIGTERM after, and it must exit with status 0."""
    proc = subprocess.Popen([sys.executable, "-m", "esair_min.cli", "std", "run", deployment,
                             "--mode", mode, "-e", ep], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        wait_for(lambda: proc.poll() is not None or deployed(), timeout=120, what=what)
        assert proc.poll() is None, proc.communicate()
        yield proc
    finally:
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, err


def call(rt, probe, do, *args):
    """Make behavior ``probe`` (comps.Probe) run ``do(*args)``; its outcome."""
    rt.put(probe, {"do": do, "args": list(args)}, timeout=5.0)
    return rt.get(probe, timeout=5.0)


def logged(caplog, logger: str) -> list[tuple[str, str]]:
    return [(r.levelname, r.getMessage()) for r in caplog.records if r.name == logger]


def in_thread(fn, *args):
    """Run ``fn(*args)`` on a daemon thread: the thread, and a list that gets its result."""
    box: list = []
    t = threading.Thread(target=lambda: box.append(fn(*args)), daemon=True)
    t.start()
    return t, box
