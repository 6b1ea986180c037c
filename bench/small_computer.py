"""ESAIR STD on the robot's own small computer (issue 37 item 1).

Stands in for a Raspberry Pi Zero 2 W class board: the robot's host side (runtime,
behaviors, drivers) runs inside a Linux control group capped at 25 % of one core and
128 MB (cgroup v1 ``cpu`` + ``memory``, or v2, whichever the machine has; needs root);
the emulated boards (and, in process mode, STARFISH's remote control center) are moved
out of it, where real hardware (or another computer) would be. Each robot and mode runs
twice, capped and uncapped (the same group without limits), and the figures are printed
side by side:

- RSS and PSS of the processes in the group (the robot side), CPU over an idle window
  as a share of one core, process start -> all components running;
- PAPA-MAN (feet polled at 8 Hz): command -> register write p99 (the emulator's trace,
  in its virtual time, mapped from time.monotonic() by its pacer's origin) against the
  line-and-tick floor (tick + oMSAAA's line time), feet samples lost;
- STARFISH: sound onset -> picture per shot against its floor (bench/toolkit/starfish.py:
  the turn's profile from standing, an odometry frame, the camera), audio frames lost.
- the control endpoint under the cap: ``ls`` and ``ping`` asked from outside the group
  (the client ``esair std`` uses), p50 / p99 and how many went unanswered in 5 s (issue
  37 item 5's goal: p99 <= 1 s); in process mode again with the behaviors' processes
  stopped (SIGSTOP), as agents starved of the CPU or cut off. STARFISH's driver renders the room's
  audio and pictures itself and follows the emulated world's true pose (a thread of its
  own): that simulation work is inside the cap; the audio's share (rendered in the
  bench's process) and the pose thread's (its own CPU) are printed and taken out.

    python bench/small_computer.py [--robots papaman,starfish] [--modes thread,process]
        [--window 10] [--n 100] [--shots 3] [--asks 20] [--caps capped,uncapped] [--tree DIR]
        [--starts N]   # only the start, N times: its CPU seconds
Prints figures; asserts nothing. Every control group it made is removed at the end
(also on an error or Ctrl-C), after every process in it has been ended.
"""

from __future__ import annotations

import argparse
import json
import os
import secrets
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "bench"
# --tree DIR: the robot side runs the esair_std of another checkout (an older commit)
TREE = Path(sys.argv[sys.argv.index("--tree") + 1]).resolve() if "--tree" in sys.argv else ROOT
PAPAMAN = ROOT / "boards" / "papaman"
# after the measured checkout's own paths (PYTHONPATH, --tree): the toolkit from this one
sys.path.append(str(ROOT))
CPU_SHARE = 0.25
WORLD_THREAD = "starfish-world"   # the emulated world's true pose (drivers/starfish/worldtap.py)
MEMORY = 128 << 20


# ---- the control group ----------------------------------------------------------------
class Cap:
    """A control group of its own (v2, or v1's ``cpu`` and ``memory`` hierarchies); with
    ``limit`` False the same group without limits (to measure alike). Removed on exit,
    after killing what is left in it (only this bench's processes are ever in it)."""

    V2 = Path("/sys/fs/cgroup/cgroup.controllers")

    def __init__(self, limit: bool, cpu: float = CPU_SHARE, memory: int = MEMORY):
        self.limit, self.cpu, self.memory = limit, cpu, memory
        self.name = f"esair-small-{secrets.token_hex(4)}"
        self.v2 = self.V2.exists()
        base = Path("/sys/fs/cgroup")
        self.dirs = [base / self.name] if self.v2 else \
            [base / "cpu" / self.name, base / "memory" / self.name]

    def __enter__(self) -> "Cap":
        made = []
        if self.v2:            # the controllers must be enabled for the root's children
            try:
                (self.dirs[0].parent / "cgroup.subtree_control").write_text("+cpu +memory")
            except OSError:
                pass           # already enabled, or refused: the limits' writes say so
        try:
            for d in self.dirs:
                d.mkdir()
                made.append(d)
            if self.limit:
                if self.v2:
                    (self.dirs[0] / "cpu.max").write_text(f"{int(self.cpu * 100000)} 100000")
                    (self.dirs[0] / "memory.max").write_text(str(self.memory))
                else:
                    (self.dirs[0] / "cpu.cfs_period_us").write_text("100000")
                    (self.dirs[0] / "cpu.cfs_quota_us").write_text(str(int(self.cpu * 100000)))
                    (self.dirs[1] / "memory.limit_in_bytes").write_text(str(self.memory))
        except BaseException:
            for d in reversed(made):
                d.rmdir()
            raise
        return self

    def join(self) -> None:
        """Put the calling process in the group (a child's preexec_fn)."""
        for d in self.dirs:
            (d / "cgroup.procs").write_text(str(os.getpid()))

    def release(self, pid: int) -> None:
        """Move ``pid`` out of the group, back to the root group."""
        for d in self.dirs:
            try:
                (d.parent / "cgroup.procs").write_text(str(pid))
            except OSError:
                pass                                  # gone meanwhile

    def pids(self) -> list[int]:
        try:
            return [int(p) for p in (self.dirs[-1] / "cgroup.procs").read_text().split()]
        except OSError:
            return []

    def memory_events(self) -> dict:
        """Peak usage (MB) and OOM kills in the group."""
        d = self.dirs[-1]
        try:
            if self.v2:
                ev = dict(line.split() for line in (d / "memory.events").read_text().splitlines())
                peak = d / "memory.peak"
                return {"peak_mb": int(peak.read_text()) / 2**20 if peak.exists() else None,
                        "oom_kills": int(ev.get("oom_kill", 0))}
            oom = dict(line.split() for line in (d / "memory.oom_control").read_text().splitlines())
            return {"peak_mb": int((d / "memory.max_usage_in_bytes").read_text()) / 2**20,
                    "oom_kills": int(oom.get("oom_kill", 0))}
        except OSError:
            return {"peak_mb": None, "oom_kills": None}

    def __exit__(self, *exc) -> None:
        for _ in range(100):
            left = self.pids()
            if not left:
                break
            for pid in left:
                try:
                    os.kill(pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
            time.sleep(0.05)
        for d in reversed(self.dirs):
            for _ in range(100):
                try:
                    d.rmdir()
                    break
                except FileNotFoundError:
                    break
                except OSError:                       # EBUSY while the last exit settles
                    time.sleep(0.05)


class Mover(threading.Thread):
    """Moves out of the group, as soon as they show, the processes that stand for real
    hardware or another computer: the emulated boards and ``remote`` agents."""

    def __init__(self, cap: Cap, remote: tuple[str, ...] = ()):
        super().__init__(daemon=True, name="mover")
        self.cap, self.remote = cap, remote
        self.done = threading.Event()
        self.moved: set[int] = set()

    def run(self) -> None:
        while not self.done.wait(0.02):
            for pid in self.cap.pids():
                if pid in self.moved:
                    continue
                try:
                    cmd = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
                except OSError:
                    continue
                spec = cmd[cmd.index(b"--spec") + 1] if b"--spec" in cmd else b""
                if b"emulate" in cmd or any(f'"name": "{r}"'.encode() in spec or
                                            f'"name":"{r}"'.encode() in spec for r in self.remote):
                    self.cap.release(pid)
                    self.moved.add(pid)


# ---- measuring the group --------------------------------------------------------------
def memory_of(pids: list[int]) -> tuple[float, float, list]:
    """(RSS MB, PSS MB) summed over ``pids``, and each one's (what it is, RSS, PSS)."""
    rss = pss = 0
    each = []
    for pid in pids:
        try:
            text = Path(f"/proc/{pid}/smaps_rollup").read_text()
            cmd = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        r = p = 0
        for line in text.splitlines():
            if line.startswith("Rss:"):
                r = int(line.split()[1])
            elif line.startswith("Pss:"):
                p = int(line.split()[1])
        rss, pss = rss + r, pss + p
        each.append((what(cmd), r / 1024, p / 1024))
    return rss / 1024, pss / 1024, each


def what(cmd: list[bytes]) -> str:
    """A process of the robot side by its command line: an agent by its component's
    name, else its module."""
    if b"--spec" in cmd:
        try:
            return str(json.loads(cmd[cmd.index(b"--spec") + 1])["name"])
        except (ValueError, KeyError, IndexError):
            return "agent"
    if b"-m" in cmd:
        return cmd[cmd.index(b"-m") + 1].decode().rsplit(".", 1)[-1]
    return "runtime"


def cpu_of(pids: list[int], children: bool = False) -> dict[int, float]:
    """CPU seconds (user + system) of each of ``pids`` (``children``: and of its
    children it has reaped)."""
    out = {}
    for pid in pids:
        try:
            fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        ticks = int(fields[11]) + int(fields[12])
        if children:
            ticks += int(fields[13]) + int(fields[14])
        out[pid] = ticks / os.sysconf("SC_CLK_TCK")
    return out


def threads_cpu(pids: list[int], comm: str) -> float:
    """CPU seconds of the threads named ``comm`` (as the OS shows them) in ``pids``."""
    total = 0.0
    for pid in pids:
        for task in Path(f"/proc/{pid}/task").glob("*") if Path(f"/proc/{pid}").exists() else ():
            try:
                if (task / "comm").read_text().strip() != comm:
                    continue
                fields = (task / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            total += (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    return total


def pct(xs: list[float], q: float) -> float:
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(q * len(xs)))] if xs else float("nan")


# ---- the emulated PAPA-MAN outside the cap, its pacer's origin known --------------------
def serve_emulator(trace: str) -> None:
    """Child: PAPA-MAN's emulated boards behind a pty, tracing; prints the pty path, the
    wall clock (time.monotonic()) and the virtual time (ns) of the pacer's origin."""
    from contextlib import ExitStack

    from esair_min.emulator.ptyserver import PtyPort, serve_pty
    from esair_min.emulator.serve import EmulateOptions, _robot_class
    from esair_min.model.validate import load_robot

    robot = load_robot(PAPAMAN)
    opts = EmulateOptions(pty=True, trace=Path(trace), live=False)
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    with ExitStack() as stack, open(trace, "w", encoding="ascii", buffering=1) as f:
        run = _robot_class(robot)(robot, opts, stack, image=None, trace=f,
                                  instance=secrets.token_hex(4), live=False)

        def on_path(path: str) -> None:      # the pacer was made just before this call
            print(path, time.monotonic(), run.sim.clock.now, flush=True)

        serve_pty(run.sim, on_path, stop.is_set, 1.0, run.idle, PtyPort())
        run.flush()


# ---- the robot side, inside the group ---------------------------------------------------
def papaman_deployment(port: str, n: int, go: str) -> dict:
    uses = {"papaman.servo.*": "command", "papaman.motion": "command"}
    return {"robot": "papaman",
            "resources": {"papaman": {"class": "esair_std.drivers.minlink:MinLink",
                                      "robot": str(PAPAMAN), "port": port, "feet_hz": 8,
                                      "allow": {"*": "command"}}},
            "behaviors": {
                "stepper": {"class": "small_computer_comps:Stepper", "n": n,
                            "every": 0.0373, "go": go, "uses": uses},
                "feet": {"class": "small_computer_comps:SeqCounter", "period": 0.05,
                         "sensor": "papaman.feet", "uses": {"papaman.feet": "read"}}}}


def starfish_deployment(store: str) -> dict:
    from bench.toolkit.starfish import deployment

    dep = deployment(store)
    dep["behaviors"]["ears"] = {"class": "small_computer_comps:SeqCounter", "period": 0.05,
                                "sensor": "starfish.mics", "uses": {"starfish.mics": "read"}}
    return dep


def _get(rt, name: str, key: str, timeout: float):
    from esair_std import StdError

    end = time.monotonic() + timeout
    while time.monotonic() < end:
        try:
            v = rt.get(name, timeout=2.0)
        except StdError:
            v = None
        if v and v.get(key):
            return v
        time.sleep(0.05)
    return None


def inner(args) -> None:
    """Child, in the group: run the robot side as ``esair std run`` does — the deployment
    (a file the bench wrote) checked in a short-lived child and handed over as plain data
    (esair_std/lean/), so this process holds no pydantic; print ``ready``
    (time.monotonic()) once every component runs, wait for ``go`` on standard input, run
    the figure, print its JSON, then wait for ``end`` and stop."""
    from esair_std import Runtime

    store, path = args.store, args.deployment
    how = "loaded here"
    try:
        from esair_std.lean.checked import checked_deployment, last
    except ImportError:      # an older checkout (--tree): it checked in the runtime's process
        dep: object = json.loads(Path(path).read_text())
    else:
        dep = checked_deployment(path, {}) or json.loads(Path(path).read_text())
        how = last["how"]
    # the control endpoint on in both modes, as ``esair std run`` has it
    with Runtime(dep, mode=args.mode, endpoint=args.endpoint,  # type: ignore[arg-type]
                 settle_heap=True, control=True) as rt:
        end = time.monotonic() + 300
        while time.monotonic() < end and \
                any(c["state"] not in ("running", "busy", "ready") for c in rt.ls()):
            time.sleep(0.02)
        print(json.dumps({"ready": time.monotonic(), "how": how}), flush=True)
        sys.stdin.readline()
        go = os.path.join(store, "go")
        out = (papaman_figure(rt, go) if args.robot == "papaman"
               else starfish_figure(rt, json.loads(args.sources)))
        print(json.dumps(out), flush=True)
        sys.stdin.readline()


def papaman_figure(rt, go: str) -> dict:
    Path(go).touch()
    got = _get(rt, "stepper", "done", 600) or {"sent": [], "errors": -1}
    return {"sent": got["sent"], "errors": got["errors"],
            "feet": rt.get("feet", timeout=10.0)}


def starfish_figure(rt, sources: list[list[float]]) -> dict:
    _get(rt, "patrol", "reached", 120)
    out = []
    for x, y in sources:
        before = rt.get("turn_and_shoot", timeout=10.0)["shots"]
        t0 = time.time()
        rt.configure("starfish.mics", "source", {"x": x, "y": y, "on": True})
        end, got = time.monotonic() + 30, None
        while time.monotonic() < end:
            r = rt.get("turn_and_shoot", timeout=10.0)
            if r["shots"] > before:
                got = r
                break
            time.sleep(0.05)
        rt.configure("starfish.mics", "source", {"x": x, "y": y, "on": False})
        out.append({"took": got["last"]["t"] - t0, "last": got["last"]} if got else None)
        time.sleep(1.0)
    return {"shots": out, "ears": rt.get("ears", timeout=10.0)}


# ---- the bench --------------------------------------------------------------------------
def warm(path: str) -> None:
    """Child (``--cache warm``): check the deployment and keep it in the cache, run as
    the robot side is (this script, from the same folder: the cache's key holds
    sys.path), so that its start reads the cache."""
    from esair_std.lean.checked import checked_deployment, last

    assert checked_deployment(path, {}) is not None, last["how"]


def one(robot: str, mode: str, limit: bool, args) -> dict:
    from bench.toolkit import free_endpoint
    from bench.toolkit.starfish import SOURCES

    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(TREE), str(BENCH), *filter(None, [os.environ.get("PYTHONPATH")])]))
    env.pop("PYTHONDONTWRITEBYTECODE", None)       # bytecode read, as installed on a robot
    emu = None
    res: dict = {"robot": robot, "mode": mode, "capped": limit}
    with Cap(limit) as cap:
        res["groups"] = [str(d) for d in cap.dirs]
        ep = free_endpoint()
        import tempfile
        tmp = tempfile.TemporaryDirectory(prefix="esair-bench-")
        store = tmp.name
        # the checked deployment's cache: empty, so the start below checks it (a miss)
        env["ESAIR_STD_CACHE"] = os.path.join(store, "cache")
        cmd = [sys.executable, str(Path(__file__).resolve()), "--inner", robot, "--mode", mode,
               "--n", str(args.n), "--endpoint", ep,
               "--sources", json.dumps([SOURCES[k % len(SOURCES)] for k in range(args.shots)]),
               "--store", store, "--deployment", os.path.join(store, "deployment.yaml")]
        if robot == "papaman":
            trace = Path(store) / "trace.txt"
            emu = subprocess.Popen([sys.executable, str(Path(__file__).resolve()),
                                    "--emulator", str(trace)], env=env,
                                   stdout=subprocess.PIPE, text=True)
            assert emu.stdout is not None
            path, wall0, virt0 = emu.stdout.readline().split()
            dep = papaman_deployment(path, args.n, os.path.join(store, "go"))
        else:
            dep = starfish_deployment(store)
        # JSON is YAML: the deployment file esair std run would read
        Path(store, "deployment.yaml").write_text(json.dumps(dep))
        if args.cache == "warm":    # checked once before (another start): read from the cache
            subprocess.run([sys.executable, str(Path(__file__).resolve()), "--warm",
                            os.path.join(store, "deployment.yaml")], env=env, cwd=TREE,
                           check=True)
        mover = Mover(cap, remote=("localize", "turn_and_shoot") if robot == "starfish" else ())
        mover.start()
        t_exec = time.monotonic()
        # in the measured checkout: a deployment's classes are looked for from there first
        child = subprocess.Popen(cmd, env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                 text=True, preexec_fn=cap.join, cwd=TREE)
        try:
            assert child.stdout is not None and child.stdin is not None
            line = child.stdout.readline()
            if not line:
                res["error"] = f"the robot side exited ({child.wait()}) before it was ready"
                return res
            said = json.loads(line)
            res["ready_s"], res["how"] = said["ready"] - t_exec, said.get("how", "")
            # the CPU the start took (every process in the group, since it began): the
            # start's floor under the cap is this over the cap's share, however loaded
            # (the deployment's checking child included: reaped, it counts in its parent's)
            res["start_cpu_s"] = sum(cpu_of(cap.pids(), children=True).values())
            if args.starts:            # --starts: the start alone (the group ends it all)
                return res
            time.sleep(args.settle)
            pids = cap.pids()
            c0, w0, t0 = cpu_of(pids), threads_cpu(pids, WORLD_THREAD), time.monotonic()
            time.sleep(args.window)
            pids = cap.pids()
            c1, w1, dt = cpu_of(pids), threads_cpu(pids, WORLD_THREAD), time.monotonic() - t0
            res["cpu_pct"] = 100 * sum(c1[p] - c0[p] for p in c1 if p in c0) / dt
            res["world_cpu_pct"] = 100 * (w1 - w0) / dt
            res["rss_mb"], res["pss_mb"], res["each"] = memory_of(pids)
            res["processes"] = len(pids)
            res.update(control_asks(ep, robot, args.asks))
            child.stdin.write("go\n")
            child.stdin.flush()
            line = child.stdout.readline()
            if not line:
                res["error"] = f"the robot side exited ({child.wait()}) during the figure"
                return res
            fig = json.loads(line)
            if mode == "process":
                # after the figure: behaviors stopped longer than the link lease (2 s)
                # lose their links, and the samples sent meanwhile (counted as missed)
                res.update(control_asks(ep, robot, args.asks, frozen=cap.pids()))
            res.update(cap.memory_events())
            child.stdin.write("end\n")
            child.stdin.flush()
            child.wait(120)
        finally:
            mover.done.set()
            if child.poll() is None:
                child.kill()
                child.wait()
            if emu is not None:
                emu.terminate()
                emu.wait(30)
    if robot == "papaman":
        res.update(register_writes(fig, trace, float(wall0), int(virt0)))
    else:
        res.update(shots(fig, dep, CPU_SHARE if limit else 1.0))
    tmp.cleanup()
    return res


def control_asks(ep: str, robot: str, n: int, frozen: list[int] | None = None) -> dict:
    """The control endpoint under the cap: ``n`` rounds of ``ls`` and ``ping`` from
    outside the group (the client ``esair std`` uses), each one's time; unanswered in 5 s
    counted. ``frozen`` (process mode: the group's processes): the behaviors' and
    reactions' processes among them are stopped (SIGSTOP) meanwhile, as agents starved of
    the CPU or cut off would be (figures ``frozen_*``); continued after."""
    from esair_std.cli.client import Client
    from esair_std.errors import StdError

    took, missed, stopped = [], 0, []
    with Client(ep, robot=robot) as c:
        try:
            if frozen is not None:
                stopped = [r["pid"] for r in c.call("ls", None, 10.0)
                           if r["kind"] in ("behavior", "reaction") and r["pid"] in frozen]
                for pid in stopped:
                    os.kill(pid, signal.SIGSTOP)
            for _ in range(n):
                for verb in ("ls", "ping"):
                    t = time.monotonic()
                    try:
                        c.call(verb, None, 5.0)
                        took.append((time.monotonic() - t) * 1e3)
                    except StdError:
                        missed += 1
                time.sleep(0.2)
        finally:
            for pid in stopped:
                os.kill(pid, signal.SIGCONT)
    tag = "frozen_" if frozen is not None else ""
    return {f"{tag}ask_p50_ms": pct(took, 0.5) if took else None,
            f"{tag}ask_p99_ms": pct(took, 0.99) if took else None,
            f"{tag}ask_n": len(took), f"{tag}ask_missed": missed,
            f"{tag}stopped": len(stopped)}


def line_and_tick_ms() -> float:
    from esair_min.model.validate import load_robot
    from esair_std.drivers.minlink import line_budget

    b = line_budget(load_robot(PAPAMAN))
    return (b.tick_s + b.line_s(len("odc100\r\n") - 1)) * 1e3


def register_writes(fig: dict, trace: Path, wall0: float, virt0: int) -> dict:
    writes, mark = [], 0.0
    for line in trace.read_text().splitlines():
        if line.startswith("@ "):
            mark = int(line[2:]) / 1e6
        elif line.startswith("W 10 ") and len(line.split()[2]) == 6:
            writes.append(mark)
    sent = [virt0 / 1e9 + (t - wall0) for t in fig["sent"]]
    lat = [(w - s) * 1e3 for s, w in zip(sent, writes)]
    return {"cmd_p50_ms": pct(lat, 0.5), "cmd_p99_ms": pct(lat, 0.99), "cmd_n": len(lat),
            "cmd_errors": fig["errors"], "writes": len(writes),
            "samples": fig["feet"]["samples"], "lost": fig["feet"]["lost"],
            "missed": fig["feet"].get("missed"), "overwritten": fig["feet"].get("overwritten")}


def audio_sim_pct(dep: dict, frames: int = 150) -> float:
    """The share of a core STARFISH's room simulation takes in the robot side's driver:
    its microphone frames (16 kHz x 4, 1024 samples each, the room's echoes and noise)
    rendered here, one after the other, as the driver does (the robot's own work, the
    frames' encoding and publishing, is not in it)."""
    from bench.toolkit.starfish import ROOM
    from esair_std.drivers.starfish.mics import RATE, AudioRenderer
    from esair_std.drivers.starfish.scene import load_scene

    o = dep["resources"]["starfish"]
    room = load_scene(str(ROOM))           # its source as in the idle window
    audio = AudioRenderer(room, snr_db=float(o.get("snr_db", 20.0)),
                          reflection_gain=float(o.get("echo", 0.0)))
    pose = tuple(o.get("pose", (1.5, 1.5, 0.0)))
    audio.render(pose)
    t = time.process_time()
    for _ in range(frames):
        audio.render(pose)
    return 100 * (time.process_time() - t) / frames * RATE / audio.frame


def shots(fig: dict, dep: dict, cpu_share: float) -> dict:
    """Each shot's time beside its floor (bench/toolkit/starfish.py), the camera's part at
    the cap's share: the driver renders the picture inside the group."""
    from bench.toolkit.starfish import shot_floor

    hz = float(dep["resources"]["starfish"].get("odometry_hz", 10))
    each = [None if s is None else (s["took"], shot_floor(s["last"], hz, cpu_share))
            for s in fig["shots"]]
    return {"shots": each, "samples": fig["ears"]["samples"], "lost": fig["ears"]["lost"],
            "sim_cpu_pct": audio_sim_pct(dep)}


def show(rows: list[dict], floor_ms: float) -> None:
    for r in rows:
        tag = f"{r['robot']:8s} {r['mode']:7s} {'capped' if r['capped'] else 'uncapped':8s}"
        if "error" in r:
            print(f"{tag} ERROR: {r['error']}")
            continue
        mem = f"peak {r['peak_mb']:.0f} MB, OOM kills {r['oom_kills']}" \
            if r.get("peak_mb") is not None else ""
        print(f"{tag} RSS {r['rss_mb']:6.1f} MB  PSS {r['pss_mb']:6.1f} MB "
              f"({r['processes']} processes; {mem})  CPU {r['cpu_pct']:5.1f} % of a core  "
              f"start -> ready {r['ready_s']:5.2f} s ({r['start_cpu_s']:.2f} s of CPU: "
              f"{r['start_cpu_s'] / CPU_SHARE:.2f} s at {CPU_SHARE:.0%} of a core; the "
              f"deployment: {r.get('how') or '?'})")
        if r["processes"] > 1:
            print(f"{'':26s} each (RSS / PSS MB): " + ", ".join(
                f"{n} {a:.1f} / {b:.1f}" for n, a, b in r["each"]))
        print(f"{'':26s} control endpoint (ls, ping; goal p99 <= 1 s): p50 "
              f"{r['ask_p50_ms']:.1f} ms, p99 {r['ask_p99_ms']:.1f} ms (n {r['ask_n']}, "
              f"unanswered {r['ask_missed']})")
        if r.get("frozen_ask_n") is not None:
            ms = ("none answered" if r["frozen_ask_p50_ms"] is None else
                  f"p50 {r['frozen_ask_p50_ms']:.1f} ms, p99 {r['frozen_ask_p99_ms']:.1f} ms")
            print(f"{'':26s} the same, {r['frozen_stopped']} behavior processes stopped "
                  f"(SIGSTOP): {ms} (n {r['frozen_ask_n']}, unanswered "
                  f"{r['frozen_ask_missed']})")
        if r["robot"] == "papaman":
            print(f"{'':26s} command -> register write p50 {r['cmd_p50_ms']:.2f} ms, "
                  f"p99 {r['cmd_p99_ms']:.2f} ms = {r['cmd_p99_ms'] / floor_ms:.2f}x the "
                  f"line-and-tick floor {floor_ms:.2f} ms (n {r['cmd_n']}, errors "
                  f"{r['cmd_errors']}); feet samples {r['samples']}, lost {r['lost']} "
                  f"(missed {r.get('missed')}, overwritten {r.get('overwritten')})")
        else:
            each = ", ".join("none in 30 s" if s is None else
                             f"{s[0]:.2f} s ({s[0] / max(s[1], 1e-3):.2f}x floor {s[1]:.2f} s)"
                             for s in r["shots"])
            print(f"{'':26s} sound -> picture: {each}; audio frames {r['samples']}, "
                  f"lost {r['lost']}")
            world = r.get("world_cpu_pct", 0.0)
            print(f"{'':26s} the simulation: the room's audio {r['sim_cpu_pct']:.1f} % of a "
                  f"core (rendered here), the world's pose tap {world:.1f} % (its thread): "
                  f"the robot side without them {r['cpu_pct'] - r['sim_cpu_pct'] - world:.1f} %")


def start_only(robot: str, mode: str, limit: bool, args) -> dict:
    """``--starts N``: N starts, each to every component running, then ended: the CPU
    each took (far less noisy than its wall time on a shared machine) and the time."""
    runs = [one(robot, mode, limit, args) for _ in range(args.starts)]
    cpu = sorted(r["start_cpu_s"] for r in runs if "error" not in r)
    wall = sorted(r["ready_s"] for r in runs if "error" not in r)
    tag = f"{robot:8s} {mode:7s} {'capped' if limit else 'uncapped':8s}"
    if not cpu:
        print(f"{tag} ERROR: {runs[-1].get('error')}")
        return {"robot": robot, "mode": mode, "capped": limit, "runs": runs}
    print(f"{tag} {len(cpu)} starts (the deployment: {runs[-1].get('how') or '?'}): CPU "
          f"median {cpu[len(cpu) // 2]:.3f} s (min {cpu[0]:.3f}, max {cpu[-1]:.3f}; "
          f"{cpu[len(cpu) // 2] / CPU_SHARE:.2f} s at {CPU_SHARE:.0%} of a core), start -> "
          f"ready median {wall[len(wall) // 2]:.2f} s (min {wall[0]:.2f}, max {wall[-1]:.2f}); "
          f"load {os.getloadavg()[0]:.1f}", flush=True)
    return {"robot": robot, "mode": mode, "capped": limit, "start_cpu_s": cpu,
            "ready_s": wall}


def _interrupted(*_) -> None:
    raise KeyboardInterrupt


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", default="papaman,starfish")
    ap.add_argument("--modes", default="thread,process")
    ap.add_argument("--caps", default="capped,uncapped")
    ap.add_argument("--window", type=float, default=10.0, help="CPU window, seconds")
    ap.add_argument("--settle", type=float, default=3.0, help="seconds after ready")
    ap.add_argument("--n", type=int, default=100, help="PAPA-MAN: commands")
    ap.add_argument("--shots", type=int, default=3, help="STARFISH: shots")
    ap.add_argument("--asks", type=int, default=20, help="rounds of ls + ping")
    ap.add_argument("--starts", type=int, default=0, metavar="N",
                    help="only start the robot side, N times each: the CPU each start took")
    ap.add_argument("--tree", metavar="DIR",
                    help="run the esair_std of the checkout DIR (an older commit) under "
                         "this bench: a before beside an after")
    ap.add_argument("--cache", choices=("cold", "warm"), default="cold",
                    help="cold: the start checks the deployment in a child (the first start "
                         "of a deployment); warm: it was checked before, the start reads the "
                         "cache (esair_std/lean/)")
    ap.add_argument("--endpoint", help=argparse.SUPPRESS)
    ap.add_argument("--inner", help=argparse.SUPPRESS)
    ap.add_argument("--sources", help=argparse.SUPPRESS)
    ap.add_argument("--mode", help=argparse.SUPPRESS)
    ap.add_argument("--store", help=argparse.SUPPRESS)
    ap.add_argument("--deployment", help=argparse.SUPPRESS)
    ap.add_argument("--emulator", help=argparse.SUPPRESS)
    ap.add_argument("--warm", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.warm:
        return warm(args.warm)
    if args.emulator:
        return serve_emulator(args.emulator)
    if args.inner:
        args.robot = args.inner
        return inner(args)
    signal.signal(signal.SIGTERM, _interrupted)      # the groups are removed then too
    if os.geteuid() != 0:
        raise SystemExit("small_computer.py needs root (it makes a control group)")
    # an installed package has its bytecode: compiled once here (a start would otherwise
    # compile every module it imports, with PYTHONDONTWRITEBYTECODE set)
    subprocess.run([sys.executable, "-m", "compileall", "-q", str(TREE / "esair_std"),
                    str(TREE / "esair_min"), str(BENCH / "small_computer_comps.py")],
                   check=False, stdout=subprocess.DEVNULL)
    floor = line_and_tick_ms()
    print(f"the robot side capped at {CPU_SHARE:.0%} of one core and {MEMORY >> 20} MB "
          f"(cgroup {'v2' if Cap.V2.exists() else 'v1'}), standing in for a Raspberry Pi "
          f"Zero 2 W class board; the emulated boards (and STARFISH's remote center in "
          f"process mode) outside; load average {os.getloadavg()[0]:.1f} on "
          f"{os.cpu_count()} cores; bytecode compiled first, as an installed package has it; "
          f"the deployment checked in a child (esair std run's way) " +
          ("before, each start reads the cache" if args.cache == "warm"
           else "at each start (no cache)"))
    rows = []
    for robot in args.robots.split(","):
        for mode in args.modes.split(","):
            for cap in args.caps.split(","):
                if args.starts:
                    rows.append(start_only(robot, mode, cap == "capped", args))
                    continue
                rows.append(one(robot, mode, cap == "capped", args))
                show(rows[-1:], floor)
    print(json.dumps({"rows": rows, "floor_ms": floor, "cpu_share": CPU_SHARE,
                      "memory_mb": MEMORY >> 20}))


if __name__ == "__main__":
    main()
