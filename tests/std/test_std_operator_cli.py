"""Issue 20: `esair std` for an operator -- one checked loader for every path, Ctrl-C and
exit codes, errors in plain words, what the CLI promises, copying an example. Every
message is asserted word for word. Observing and commanding a running robot:
test_std_operator_lab.py."""

from __future__ import annotations

import ctypes
import json
import os
import platform
import re
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from esair_std.hosts.resource_host import OPEN_TIMEOUT
from tests.support import std
from tests.support.std import (MODES, ROOT, ask, components, free_endpoint, lab_started,
                                processes, wait_for)

FIX = ROOT / "tests" / "fixtures" / "std_operator"
#: seconds each; the papaman tests run the emulator behind a pty
pytestmark = pytest.mark.slow


def environ(extra: dict | None = None) -> dict:
    """This checkout first on the children's path (not an installed copy)."""
    path = os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])
    return dict(os.environ, COLUMNS="200", PYTHONPATH=path, **(extra or {}))


def esair(*args: str, cwd: str | Path = ROOT, env: dict | None = None,
          stdin: str | None = None) -> subprocess.CompletedProcess:
    """``esair std ARGS``: a child process from ``cwd`` with this checkout first on its
    path, or in this process (tests.support.std.esair)."""
    path = os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])
    return std.esair(*args, check=False, cwd=cwd, stdin=stdin,
                     env={"PYTHONPATH": path, **(env or {})})


def refused(*args: str) -> subprocess.CompletedProcess:
    """``esair std ARGS`` that must stop before anything starts (a usage error, a
    deployment refused as it is read), in this process (tests.support.std.std_cli: the
    command line's own entry point, an uncaught exception raised) rather than a child's
    interpreter start."""
    return std.std_cli(*args)


def cmdline(pid: int) -> bytes:
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as f:
            return f.read()
    except OSError:
        return b""


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


def spawn_run(*args: str, cwd: str | Path = ROOT, env: dict | None = None) -> subprocess.Popen:
    """``esair std run ARGS`` in its own session, as a terminal runs it (a terminal's
    Ctrl-C goes to the whole process group)."""
    return subprocess.Popen([sys.executable, "-m", "esair_min.cli", "std", "run", *args],
                            cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True, env=environ(env))


def answers(ep: str) -> bool:
    return ask(ep, "ping") is not None


@pytest.fixture
def robot(request):
    """start(deployment, *args) -> (process, endpoint) of `esair std run` with the robot
    answering on its control endpoint; SIGTERM and exit status 0 after the test."""
    started = []

    def start(deployment: str, *args: str, cwd: str | Path = ROOT):
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
    run = refused("run", str(path), "--port", "/dev/null", "--run", "0", "--no-control")
    assert (check.returncode, check.stderr) == (1, f"error: {path}:{message}\n")
    assert (run.returncode, run.stderr) == (1, f"error: {path}:{message}\n")


def test_port_on_a_deployment_without_a_port_option_is_an_error():
    path = FIX / "no_port.yaml"
    r = refused("run", str(path), "--port", "/dev/ttyUSB0", "--run", "0", "--no-control")
    assert (r.returncode, r.stderr) == (
        1, f"error: {path}: --port /dev/ttyUSB0: no resource of this deployment has a "
           "'port' option\n")
    r = refused("run", str(path), "--trace", "t.txt", "--run", "0", "--no-control")
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
        first = proc.stderr.readline()            # printed once every component started
        kids = children_of(proc.pid)
        agents = [k for k in kids if b"esair_std.hosts.zygote" not in cmdline(k)]
        # 5 components, 4 resource entries; process mode also has its fork server
        assert len(agents) == (0 if mode == "thread" else 9)
        assert len(kids) - len(agents) == (0 if mode == "thread" else 1)
        os.killpg(proc.pid, signal.SIGINT)        # what a terminal's Ctrl-C does
        out, err = proc.communicate(timeout=60)
        err = first + err
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
    r = refused(*args)
    assert r.returncode == 2
    assert r.stderr.splitlines()[-1] == f"Error: {message}"


def error_of(*args: str, **kw) -> tuple[int, str]:
    r = esair(*args, **kw)
    return r.returncode, r.stderr


# ---- 3. errors a user understands

@pytest.mark.parametrize("case,message", [
    ("long_number", "4:34: a number of 5000 characters is too long to read (at most 4300 "
                    "digits); quote it to keep it as text"),
    ("tab_before_comment", "2:11: a tab before a comment: the YAML reader takes only spaces "
                           "between a value and its '#'; replace the tab by spaces"),
    ("tab_between_values", "2:7: a tab character between values: the YAML reader separates "
                           "them with spaces only; replace the tab by spaces"),
    ("allow_lone_bracket", "4:58: '[' in 'allow' has a '[' or ']' without its pair: in a "
                           "pattern, [...] holds the characters one place may be, e.g. "
                           "'arm[12]'"),
])
def test_deployment_faults_in_plain_words(case, message):
    path = FIX / f"{case}.yaml"
    assert error_of("check", "--no-import", str(path)) == (1, f"error: {path}:{message}\n")


def test_brackets_in_pairs_are_a_pattern():
    r = esair("check", "--no-import", str(FIX / "allow_brackets.yaml"))
    assert r.returncode == 0, r.stderr
    assert "allow arm[12]: read, [!x]*: command" in r.stdout


@pytest.mark.pty
def test_a_disconnected_serial_device_is_said_in_plain_words():
    """pySerial's words for a pty whose other end closed (a robot unplugged), as the
    link reports them (esair std ls shows them as the reason)."""
    import pty

    import serial

    from esair_min.serialport import describe
    master, slave = pty.openpty()
    port = serial.Serial(os.ttyname(slave), timeout=1)
    os.close(master)
    try:
        with pytest.raises(serial.SerialException) as exc:
            port.read(10)
    finally:
        port.close()
        os.close(slave)
    assert describe(exc.value) == ("the device disconnected (unplugged, or another program "
                                    "uses the port)")


def test_the_live_table_keeps_one_line_a_row():
    from rich.console import Console

    from esair_std.cli.top import grouped, render
    long = "link down: " + "x" * 300
    rows = [dict(name="d", kind="driver", state="lost", pid=1, host="h", restarts=0,
                 reason=long, parent="", count=0),
            dict(name="d.feet", kind="sensor", state="lost", pid=1, host="h", restarts=0,
                 reason=long, parent="d", count=0)]
    console = Console(width=100, record=True)
    console.print(render(grouped(rows), {}, "r"))
    lines = console.export_text().splitlines()
    assert len(lines) == 7                    # title, 3 rules, header, 2 rows
    assert lines[4].startswith("│ d ") and lines[5].startswith("│   .feet ")
    assert all(line.endswith(("┓", "┃", "┩", "│", "┘")) for line in lines[1:])


def test_the_live_table_keeps_a_row_whose_counters_do_not_come():
    """A component whose inspect goes unanswered (a loaded machine, a busy child) stays
    in the table with its rate unknown, rather than vanishing from it."""
    from rich.console import Console

    from esair_std.cli.top import render, snapshot
    from esair_std.errors import TransportError

    class Slow:           # the control client's two questions, one of them unanswered
        robot = "r"

        def call(self, verb, body):
            if verb == "ls":
                return [dict(name=n, kind="behavior", state="running", pid=1, host="h",
                             restarts=0, reason="", parent="") for n in ("a", "b")]
            if body["name"] == "b":
                raise TransportError("the runtime did not answer 'inspect'")
            return {"counters": {"steps": 7}}

    rows = snapshot(Slow())
    assert [(r["name"], r["count"]) for r in rows] == [("a", 7), ("b", None)]
    console = Console(width=100, record=True)
    console.print(render(rows, {}, "r"))
    b = [line for line in console.export_text().splitlines() if line.startswith("│ b ")]
    assert len(b) == 1 and b[0].split("│")[7].strip() == "?"


# ---- 4. what the CLI promises

def test_run_listens_on_esair_std_endpoint(tmp_path):
    ep, other = free_endpoint(), free_endpoint()
    dep = tmp_path / "lab.yaml"
    text = (ROOT / "esair_std" / "examples" / "lab" / "lab.yaml").read_text()
    dep.write_text(text.replace("endpoint: tcp/127.0.0.1:7447", f"endpoint: {other}"))
    (tmp_path / "lab.py").write_text((ROOT / "esair_std" / "examples" / "lab" / "lab.py")
                                     .read_text())
    r = esair("run", str(dep), "--run", "0.5", env={"ESAIR_STD_ENDPOINT": ep})
    assert r.returncode == 0, r.stderr
    assert r.stderr.splitlines()[0] == (
        f"robot 'lab' running in thread mode, control endpoint {ep} (10 components)")


# ---- 5. the emulated robot's options, the live table / 6. copy an example

@pytest.mark.pty
def test_trace_and_scenario_reach_the_emulated_robot(tmp_path):
    r = esair("run", "papaman", "--trace", "trace.txt", "--scenario", "push", "--run", "0.5",
              "--no-control", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    trace = (tmp_path / "trace.txt").read_text()        # relative to where it was run
    assert trace.startswith("# esair-trace 1\n@ 0\n")
    assert refused("run", "papaman", "--trace", "t.txt", "--port", "/dev/ttyUSB0",
                   "--run", "0").stderr.splitlines()[-1] == (
        "Error: --trace is for the emulated robot, not --port /dev/ttyUSB0")


def top_title(ep: str) -> str:
    """The title of the table `esair std top --count 1` leaves on the screen."""
    top = esair("top", "--count", "1", "--interval", "0.1", "-e", ep)
    assert top.returncode == 0, top.stderr
    out = top.stdout
    return [line.strip() for line in out.splitlines() if "ESAIR STD" in line][-1]


def gated(tmp_path: Path, limit: float = 60) -> Path:
    """A deployment whose one resource opens once ``tmp_path/go`` exists (at most
    ``limit`` s), and one behavior, added after it."""
    dep = tmp_path / "gated.yaml"
    dep.write_text("robot: gated\nendpoint: tcp/127.0.0.1:7447\nresources:\n"
                   f"  gate: {{class: 'tests.support.comps:GatedOpen', gate: '{tmp_path}/go',"
                   f" limit: {limit}, allow: {{'*': read}}}}\n"
                   "behaviors:\n  sink: {class: 'tests.support.comps:Sink'}\n")
    return dep


#: the tgkill system call's number (a signal to one thread of another process)
TGKILL = {"x86_64": 234, "aarch64": 131}


def sigterm_to_a_thread(pid: int) -> None:
    """SIGTERM to one of ``pid``'s threads other than its main thread, as the kernel
    may deliver a process's signal (the main thread then is not woken by it)."""
    tids = [int(t) for t in os.listdir(f"/proc/{pid}/task") if int(t) != pid]
    assert tids, "the process has one thread only"
    libc = ctypes.CDLL(None, use_errno=True)
    assert libc.syscall(TGKILL[platform.machine()], pid, tids[-1], signal.SIGTERM) == 0


@pytest.mark.parametrize("to", ["process", "thread"])
@pytest.mark.parametrize("mode", MODES)
def test_sigterm_while_starting_stops_at_once(mode, to, tmp_path):
    """SIGTERM (a service manager's stop) while a resource's open() hangs interrupts the
    start, as Ctrl-C does: exit status 0, and no process of the robot is left; also
    when the kernel hands the signal to a thread other than the main thread, which then
    waits on the open (a stop lost until the open's time limit, OPEN_TIMEOUT)."""
    ep = free_endpoint()
    proc = spawn_run(str(gated(tmp_path, limit=600)), "--mode", mode, "-e", ep, "--no-top")
    try:
        wait_for(lambda: proc.poll() is not None or answers(ep), timeout=60,
                 what="the robot answering")
        assert ask(ep, "ping")["starting"] is True
        if to == "process":
            proc.send_signal(signal.SIGTERM)
        else:
            sigterm_to_a_thread(proc.pid)
        # the open alone would hold it 600 s, a lost signal until OPEN_TIMEOUT
        _, err = proc.communicate(timeout=OPEN_TIMEOUT * 0.75)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate(timeout=10)
    assert proc.returncode == 0, err
    assert "Traceback" not in err
    wait_for(lambda: not [p for p, _, cmd in processes() if str(tmp_path).encode() in cmd],
             timeout=30, what="no process of the robot left")


@pytest.mark.parametrize("mode", MODES)
def test_ls_and_top_say_the_robot_is_still_starting(robot, mode, tmp_path):
    """The runtime answers while it starts, adding resources then behaviors: a list
    then is not the whole robot, and ls and top say so until the start is over."""
    dep = gated(tmp_path)
    _, ep = robot(str(dep), "--mode", mode)
    r = esair("ls", "-e", ep)
    assert "sink" not in r.stdout
    assert r.stderr == "robot 'gated' is still starting: more of its components may be " \
                       "listed soon\n"
    out = json.loads(esair("ls", "--json", "-e", ep).stdout)
    assert out["starting"] is True
    # the resource still opening is neither ready nor a driver (it has no children yet)
    assert [(r["name"], r["kind"], r["state"]) for r in out["components"]] == [
        ("gate", "resource", "starting")]
    assert top_title(ep) == "ESAIR STD — robot gated (starting)"
    (tmp_path / "go").touch()                          # the resource opens
    wait_for(lambda: lab_started(ep, ("gate", "sink")), timeout=60, what="the start over")
    assert json.loads(esair("ls", "--json", "-e", ep).stdout)["starting"] is False
    r = esair("ls", "-e", ep)
    assert "sink" in r.stdout and r.stderr == ""
    rows = {r["name"]: r for r in components(ep)}
    assert (rows["gate"]["kind"], rows["gate"]["state"]) == ("sensor", "ready")
    assert top_title(ep) == "ESAIR STD — robot gated"


@pytest.mark.pty
@pytest.mark.parametrize("mode", MODES)
def test_papaman_from_the_command_line(robot, mode):
    """The live table groups the driver's children; a put the sequencer refuses says
    why; one command by hand as the operator; the feet's latest sample."""
    _, ep = robot("papaman", "--mode", mode)
    # every component by name: the runtime answers while it starts and adds its
    # behaviors after its resources, so "16 ready" held before 'logger' was listed (CI)
    servos = [f"papaman.servo.{side}_{joint}" for side in "lr" for joint in (
        "hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll")]
    names = ("sequencer", "watcher", "logger", "papaman", "papaman.motion", "papaman.feet",
             "papaman.notices", *servos)
    wait_for(lambda: lab_started(ep, names), timeout=60,
             what="papaman ready")     # process mode on a loaded machine: 10 s was seen to run out
    top = esair("top", "--count", "1", "--interval", "0.1", "-e", ep)
    assert top.returncode == 0, top.stderr
    out = top.stdout
    names = [line.split("│")[1].strip() for line in out.splitlines()
             if line.startswith("│")]
    assert names == ["sequencer", "watcher", "logger", "papaman", ".servo.* (12)",
                     ".motion", ".feet", ".notices"]
    # a behavior refuses a put by raising Refused in receive(): the sender is told why
    assert error_of("put", "sequencer", '["dnce"]', "-e", ep) == (
        1, "error: put to 'sequencer' failed: 'sequencer' refused it: unknown operation "
           "'dnce' (known: stop, stand_up, sit_down, prostrate, dance, auto_balance); "
           "nothing queued\n")
    r = esair("put", "sequencer", '["stand_up"]', "-e", ep)
    assert (r.returncode, r.stdout) == (0, "delivered\n"), r.stderr
    rows = {r["name"]: r for r in json.loads(esair("ls", "--json", "-e", ep).stdout)[
        "components"]}
    assert rows["sequencer"]["state"] == "running"
    info = json.loads(esair("inspect", "sequencer", "-e", ep).stdout)
    assert info["counters"]["refused_puts"] == 1
    # the bundled papaman grants the operator command: one command by hand
    r = esair("send", "papaman.motion", "stand", "-e", ep)
    assert (r.returncode, r.stdout) == (0, '"t"\n'), r.stderr
    # the quiet scenario's jitter ends 1 s into the robot's time: every sensor at 512
    wait_for(lambda: json.loads(esair("sample", "papaman.feet", "-e", ep).stdout)[
        "groups"] == {"left_foot": 2048, "right_foot": 2048}, timeout=30,
        what="the feet at rest")
    # a setting it has not: the settings it has are listed
    assert error_of("configure", "papaman.feet", "gain", "2", "-e", ep) == (
        1, "error: papaman.feet: no setting 'gain' (settings: rate_hz, feet_hz)\n")


@pytest.mark.pty
def test_new_copies_an_example_that_checks_and_runs(tmp_path):
    """The copy is a robot of its own (issue 34 item 5): its file and robot named after
    its folder, a port of its own, comments that run it from there."""
    folder = tmp_path / "mybot"
    r = esair("new", "papaman", str(folder))      # (in this process: the folder is absolute)
    dep = folder / "mybot.yaml"
    text = dep.read_text()
    endpoint = re.search(r"^endpoint: (tcp/127\.0\.0\.1:(\d+))$", text, re.M)
    assert endpoint and endpoint[2] != "7447"
    endpoint = endpoint[1]
    assert (r.returncode, r.stdout) == (0, f"wrote {dep}\n"
                                           f"wrote {folder}/papaman_behaviors.py\n"
                                           f"run it: esair std run {folder}\n"
                                           f"robot 'mybot' listens on {endpoint}: other "
                                           f"terminals give -e {endpoint} (or export "
                                           f"ESAIR_STD_ENDPOINT={endpoint})\n")
    assert sorted(p.name for p in folder.iterdir()) == ["mybot.yaml", "papaman_behaviors.py"]
    assert "\nrobot: mybot\n" in text and "\n    robot: papaman " in text   # the board files
    assert "esair std run papaman" not in text
    assert f"#   esair std run {folder}   " in text
    assert f"# Other terminals: export ESAIR_STD_ENDPOINT={endpoint}" in text
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    r = esair("check", str(folder), cwd=elsewhere)
    assert r.returncode == 0 and r.stdout.endswith("classes: 4 imported\nok\n"), r.stderr
    assert r.stdout.startswith("robot 'mybot': mode thread")
    # relative paths in the deployment are relative to its folder, not to the cwd
    assert text.count("      scenario: quiet\n") == 1
    dep.write_text(text.replace("      scenario: quiet\n",
                                "      scenario: quiet\n      trace: trace.txt\n"))
    r = esair("run", str(folder), "--run", "0.5", cwd=elsewhere)
    assert r.returncode == 0, r.stderr
    assert f"robot 'mybot' running in thread mode, control endpoint {endpoint}" in r.stderr
    assert (folder / "trace.txt").read_text().startswith("# esair-trace 1\n")
    assert not (elsewhere / "trace.txt").exists()
    # the other examples likewise: each copy its own robot on its own port
    ports = {endpoint}
    for example in ("lab", "starfish"):
        r = esair("new", example, str(tmp_path / f"my-{example}"))
        copy = (tmp_path / f"my-{example}" / f"my-{example}.yaml").read_text()
        assert f"\nrobot: my_{example}\n" in copy and f"esair std run {example}" not in copy
        ports.add(re.search(r"^endpoint: (.*)$", copy, re.M)[1])
        r = esair("check", str(tmp_path / f"my-{example}"), cwd=elsewhere)
        assert r.returncode == 0, r.stderr
    assert len(ports) == 3
    assert error_of("new", "papaman", str(folder)) == (
        1, f"error: {folder}/mybot.yaml exists already: choose a new folder, or move it "
           "away (nothing was written)\n")
    assert error_of("new", "papamn", str(tmp_path / "x")) == (
        1, "error: no bundled example named 'papamn' (did you mean 'papaman'?) (bundled: "
           "lab, papaman, starfish)\n")
