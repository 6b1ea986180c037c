"""Issue 20: `esair std` for an operator -- one checked loader for every path, Ctrl-C and
exit codes, errors in plain words, what the CLI promises, observing and commanding the
robot, copying an example. Every message is asserted word for word."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
STD = Path(__file__).resolve().parent
FIX = ROOT / "tests" / "fixtures" / "std_operator"
MODES = ["thread", "process"]


def free_endpoint() -> str:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return f"tcp/127.0.0.1:{s.getsockname()[1]}"


def environ(extra: dict | None = None) -> dict:
    """This checkout first on the children's path (not an installed copy)."""
    path = os.pathsep.join([str(ROOT), str(STD), os.environ.get("PYTHONPATH", "")])
    return dict(os.environ, COLUMNS="200", PYTHONPATH=path, **(extra or {}))


def esair(*args: str, cwd: str | Path = STD, env: dict | None = None,
          stdin: str | None = None) -> subprocess.CompletedProcess:
    """``esair std ARGS`` in a child process."""
    return subprocess.run([sys.executable, "-m", "esair_min.cli", "std", *args],
                          capture_output=True, text=True, timeout=90, cwd=cwd, input=stdin,
                          env=environ(env))


def wait_for(fn, timeout: float = 30.0, what: str = "condition"):
    deadline = time.monotonic() + timeout
    while True:
        v = fn()
        if v:
            return v
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}; last value {v!r}")
        time.sleep(0.05)


def children_of(pid: int) -> list[int]:
    """Every live process below ``pid`` (children, grandchildren, ...)."""
    parent = {}
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                with open(f"/proc/{d}/stat") as f:
                    parent[int(d)] = int(f.read().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                pass
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        kids = [c for c, pp in parent.items() if pp == p]
        out += kids
        todo += kids
    return out


def spawn_run(*args: str, cwd: str | Path = STD, env: dict | None = None) -> subprocess.Popen:
    """``esair std run ARGS`` in its own session, as a terminal runs it (a terminal's
    Ctrl-C goes to the whole process group)."""
    return subprocess.Popen([sys.executable, "-m", "esair_min.cli", "std", "run", *args],
                            cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True, env=environ(env))


def answers(ep: str) -> bool:
    return esair("ls", "-e", ep).returncode == 0


@pytest.fixture
def robot(request):
    """start(deployment, *args) -> (process, endpoint) of `esair std run` with the robot
    answering on its control endpoint; SIGTERM and exit status 0 after the test."""
    started = []

    def start(deployment: str, *args: str, cwd: str | Path = STD):
        ep = free_endpoint()
        proc = spawn_run(deployment, "-e", ep, "--no-top", *args, cwd=cwd)
        started.append(proc)
        wait_for(lambda: proc.poll() is not None or answers(ep), timeout=60,
                 what="the robot answering")
        assert proc.poll() is None, proc.communicate()
        return proc, ep

    yield start
    for proc in started:
        if proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
        assert proc.returncode == 0, err


# ---- 1. one checked loader for every path

@pytest.mark.parametrize("case,message", [
    ("billion_laughs", "8:5: aliases expand this document to more than 100000 values (a "
                       "billion-laughs style alias bomb?); write the values out instead of "
                       "nesting '*' aliases"),
    ("duplicate_port", "7:5: duplicate key 'port' (first given at line 6); keep only one of "
                       "them"),
])
def test_run_with_port_reads_the_file_as_check_does(case, message):
    path = FIX / f"{case}.yaml"
    check = esair("check", "--no-import", str(path))
    run = esair("run", str(path), "--port", "/dev/null", "--run", "0", "--no-control")
    assert (check.returncode, check.stderr) == (1, f"error: {path}:{message}\n")
    assert (run.returncode, run.stderr) == (1, f"error: {path}:{message}\n")


def test_port_on_a_deployment_without_a_port_option_is_an_error():
    path = FIX / "no_port.yaml"
    r = esair("run", str(path), "--port", "/dev/ttyUSB0", "--run", "0", "--no-control")
    assert (r.returncode, r.stderr) == (
        1, f"error: {path}: --port /dev/ttyUSB0: no resource of this deployment has a "
           "'port' option\n")
    r = esair("run", str(path), "--trace", "t.txt", "--run", "0", "--no-control")
    assert (r.returncode, r.stderr) == (
        1, f"error: {path}: --trace: no resource of this deployment runs an emulated robot "
           "(port: emulate)\n")


# ---- 2. Ctrl-C and exit codes

@pytest.mark.parametrize("mode", MODES)
def test_ctrl_c_stops_with_one_line_and_status_130(mode):
    ep = free_endpoint()
    proc = spawn_run("lab", "--mode", mode, "-e", ep, "--no-top")
    try:
        wait_for(lambda: proc.poll() is not None or answers(ep), timeout=60,
                 what="the robot answering")
        kids = children_of(proc.pid)
        assert len(kids) == (0 if mode == "thread" else 9)
        os.killpg(proc.pid, signal.SIGINT)        # what a terminal's Ctrl-C does
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130
    assert err.splitlines() == [
        f"robot 'lab' running in {mode} mode, control endpoint {ep} (10 components)",
        "interrupted: robot 'lab' stopped"]
    assert out == ""
    assert [k for k in kids if os.path.exists(f"/proc/{k}")] == []


@pytest.mark.parametrize("args,message", [
    (["put", "logger", "1", "--timeout", "-1"],
     "Invalid value for '--timeout': -1.0 is not in the range 0<=x<=3600."),
    (["get", "logger", "--timeout", "soon"],
     "Invalid value for '--timeout': 'soon' is not a valid float range."),
    (["add", "x", "lab:Logger", "--period", "0"],
     "Invalid value for '--period': 0.0 is not in the range x>0."),
    (["ls", "-e", "tcp/127.0.0.1:99999"],
     "Invalid value for '-e' / '--endpoint' (env var: 'ESAIR_STD_ENDPOINT'): port must be a "
     "number from 0 to 65535, not '99999'"),
    (["run", "lab", "--run", "-1"],
     "Invalid value for '--run': -1.0 is not in the range x>=0."),
    (["run", "lab", "-e", "tcp/127.0.0.1"],
     "Invalid value for '-e' / '--endpoint' (env var: 'ESAIR_STD_ENDPOINT'): needs a host "
     "and a port: PROTOCOL/HOST:PORT such as tcp/127.0.0.1:7447, not text 'tcp/127.0.0.1'"),
    (["certs", "/tmp/never", "--days", "0"],
     "Invalid value for '--days': 0 is not in the range x>=1."),
])
def test_bad_option_values_are_usage_errors(args, message):
    r = esair(*args)
    assert r.returncode == 2
    assert r.stderr.splitlines()[-1] == f"Error: {message}"
