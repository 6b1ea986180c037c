"""The floors bench/small_computer.py's figures are given against (issue 37 item 2).

What the robot side cannot go below with the libraries it uses, each measured in a
process of its own that does only that:

- thread mode: ``python -P`` + one Zenoh session listening on the loopback (the control
  endpoint) + the deployment loader (pydantic) + the robot's board model (+ numpy for
  STARFISH, whose driver and behaviors compute with it): RSS, PSS, and
  the CPU seconds that took (the start's floor; under the cap, over its 25 %);
- process mode: that runtime-side process (without the board model), a zygote that
  imported Zenoh's module only, and one child forked from it per component, each with
  its own session connected to the runtime, the resource entry's child loading the board
  model: the PSS of them all;
- the same without the checker ("lean": ``esair std run`` checks the deployment and the
  board files in a short-lived child and hands the robot side plain data, esair_std/lean/):
  no pydantic, no board model, only ``json``; and the CPU that checking child takes
  (the deployment loader and the board model, in a process of its own that then exits:
  a start without the cache pays it, a start from the cache does not).

    python bench/small_computer_floors.py [--robots papaman,starfish] [--children N]
Prints figures; asserts nothing. Uses no control group (memory and CPU seconds do not
depend on the cap).
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CPU_SHARE = 0.25
# the component processes bench/small_computer.py's group holds in process mode
# (STARFISH's localize and turn_and_shoot run outside it, on the remote centre)
CHILDREN = {"papaman": 3, "starfish": 4}

THREAD = """
import json, os, sys, time
import zenoh
c = zenoh.Config()
c.insert_json5("mode", '"peer"')
c.insert_json5("listen/endpoints", json.dumps([sys.argv[1]]))
c.insert_json5("scouting/multicast/enabled", "false")
s = zenoh.open(c)
if sys.argv[4]:                  # lean: the plain data a checked deployment is handed as
    import json
    json.loads('{"robot": "floor", "specs": []}')
else:
    from esair_std.deploy import load_deployment
    load_deployment({"robot": "floor"})
    if sys.argv[2]:
        from esair_min.model.validate import load_robot
        load_robot(sys.argv[2])
if sys.argv[3]:
    import numpy  # noqa: F401 - STARFISH's driver and behaviors compute with it
print(time.process_time(), flush=True)
sys.stdin.readline()
os._exit(0)
"""


def free_endpoint() -> str:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return f"tcp/127.0.0.1:{sock.getsockname()[1]}"


def memory(pid: int) -> tuple[float, float]:
    rss = pss = 0
    for line in Path(f"/proc/{pid}/smaps_rollup").read_text().splitlines():
        if line.startswith("Rss:"):
            rss = int(line.split()[1])
        elif line.startswith("Pss:"):
            pss = int(line.split()[1])
    return rss / 1024, pss / 1024


CHECKER = """
import gc, sys, time
gc.disable()                  # as esair std run's checking child
t0 = time.process_time()      # a forked child does not pay python's own start
from esair_std.deploy import load_deployment
load_deployment({"robot": "floor"})
from esair_min.model.validate import load_robot
load_robot(sys.argv[1])
print(time.process_time() - t0, time.process_time(), flush=True)
"""


def checker_cpu(board: str) -> tuple[float, float]:
    """CPU seconds a process takes to check a deployment and load the board model: (the
    work alone, as a child forked from a started python pays it; with python's start)."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])]))
    out = subprocess.run([sys.executable, "-P", "-c", CHECKER, board], env=env,
                         capture_output=True, text=True, check=True)
    work, total = out.stdout.split()
    return float(work), float(total)


def runtime_side(ep: str, board: str, numpy: bool = False,
                 lean: bool = False) -> tuple[subprocess.Popen, float]:
    """The runtime-side floor process, its CPU seconds once it holds all of it."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])]))
    proc = subprocess.Popen([sys.executable, "-P", "-c", THREAD, ep, board,
                             "numpy" if numpy else "", "lean" if lean else ""], env=env,
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    return proc, float(proc.stdout.readline())


_IMPORT_CPU: dict[str, float] = {}


def forked_children(ep: str, board: str, n: int) -> tuple[list[int], list[int], float]:
    """``n`` children forked from this process (which imported Zenoh's module only),
    each with its own session connected to ``ep``; the first loads the board model.
    Each waits until the pipe whose writing end is returned with it closes; and the
    CPU seconds Zenoh's import took here."""
    t = time.process_time()
    import zenoh
    import_cpu = _IMPORT_CPU.setdefault("zenoh", time.process_time() - t)   # the first's

    gc.collect()
    gc.freeze()
    pids, ready = [], []
    for i in range(n):
        r, w = os.pipe()
        done_r, done_w = os.pipe()
        pid = os.fork()
        if pid == 0:
            os.close(r)
            os.close(done_w)
            c = zenoh.Config()
            c.insert_json5("mode", '"peer"')
            c.insert_json5("connect/endpoints", json.dumps([ep]))
            c.insert_json5("listen/endpoints", '["tcp/127.0.0.1:0"]')
            c.insert_json5("scouting/multicast/enabled", "false")
            s = zenoh.open(c)                                   # noqa: F841 - held open
            if i == 0 and board:
                from esair_min.model.validate import load_robot
                load_robot(board)
            os.write(w, b"1")
            os.read(done_r, 1)
            os._exit(0)
        os.close(w)
        os.close(done_r)
        pids.append(pid)
        ready.append((r, done_w))
    for r, _ in ready:
        os.read(r, 1)
        os.close(r)
    return pids, [w for _, w in ready], import_cpu


def cpu_s(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", default="papaman,starfish")
    ap.add_argument("--children", type=int, help="process mode: component processes "
                    "(default: as in bench/small_computer.py's group, PAPA-MAN 3, STARFISH 4)")
    args = ap.parse_args()
    sys.path.insert(0, str(ROOT))
    for robot in args.robots.split(","):
        board = str(ROOT / "boards" / robot)
        lean_cpu = 0.0
        for lean in (False, True):
            lean_cpu = floors(robot, board, lean, args.children or CHILDREN[robot])
        work, total = checker_cpu(board)
        print(f"{robot:8s} the checking child (deployment loader + board model, then exits): "
              f"{work:.3f} s of CPU ({total:.3f} s as a process of its own, python's start "
              f"included); a first start's floor in thread mode (the lean floor + that "
              f"work): {lean_cpu + work:.3f} s of CPU ({(lean_cpu + work) / CPU_SHARE:.2f} s "
              f"at {CPU_SHARE:.0%} of a core)")


def floors(robot: str, board: str, lean: bool, n: int) -> float:
    """Print the floors; return the thread-mode floor's CPU seconds."""
    held = "json (a deployment checked elsewhere)" if lean else \
        "the deployment loader + the board model"
    ep = free_endpoint()
    proc, cpu = runtime_side(ep, board, numpy=robot == "starfish", lean=lean)
    time.sleep(1.0)
    rss, pss = memory(proc.pid)
    extra = " + numpy" if robot == "starfish" else ""
    print(f"{robot:8s} thread floor{' lean' if lean else ''} (python + a Zenoh session + "
          f"{held}{extra}): RSS {rss:.1f} MB, PSS {pss:.1f} MB; {cpu:.3f} s of CPU "
          f"to hold it (start floor {cpu / CPU_SHARE:.2f} s at {CPU_SHARE:.0%} of a core)")
    assert proc.stdin is not None
    proc.stdin.write("\n")
    proc.stdin.flush()
    proc.wait(30)
    ep = free_endpoint()
    proc, runtime_cpu = runtime_side(ep, "", lean=lean)
    pids, release, import_cpu = forked_children(ep, "" if lean else board, n)
    start_cpu = runtime_cpu + import_cpu + sum(cpu_s(p) for p in pids)
    time.sleep(1.0)
    rows = [("runtime", proc.pid), ("zygote", os.getpid())] + \
        [(f"child {i + 1}", p) for i, p in enumerate(pids)]
    each = [(name, *memory(pid)) for name, pid in rows]
    print(f"{robot:8s} process floor{' lean' if lean else ''} ({n} forked children): PSS "
          f"{sum(e[2] for e in each):.1f} MB (RSS {sum(e[1] for e in each):.1f}): " +
          ", ".join(f"{n} {r:.1f} / {p:.1f}" for n, r, p in each) +
          f"; {start_cpu:.3f} s of CPU to hold it (start floor "
          f"{start_cpu / CPU_SHARE:.2f} s at {CPU_SHARE:.0%} of a core)")
    for w in release:
        os.close(w)
    for pid in pids:
        os.waitpid(pid, 0)
    assert proc.stdin is not None
    proc.stdin.write("\n")
    proc.stdin.flush()
    proc.wait(30)
    return cpu


if __name__ == "__main__":
    main()
