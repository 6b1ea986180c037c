"""`esair std run papaman`, the newcomer's command, end to end in both modes: its own
emulated robot as a child process, `esair std put` to the sequencer from another
process, nothing left behind; `--port` pointing the same deployment at another robot
(`--top` shows the live table); a feet rate beyond the line's budget refused in one
line."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from tests.support.std import MODES, components, esair, free_endpoint, processes, std_run, wait_for

from esair_std.drivers.minlink.emulated import EmulatedRobot

pytestmark = pytest.mark.pty

HERE = Path(__file__).resolve().parents[2]  # the checkout: tests.support imports from here
ROOT = HERE
EXAMPLE = ROOT / "esair_std" / "examples" / "papaman"


def descendants(pid: int) -> set[int]:
    children: dict[int, list[int]] = {}
    for p, ppid, _ in processes():
        children.setdefault(ppid, []).append(p)
    out, todo = set(), [pid]
    while todo:
        for c in children.get(todo.pop(), []):
            out.add(c)
            todo.append(c)
    return out


def running(pids: set[int]) -> list[int]:
    """Those of ``pids`` still running (a zombie waiting to be reaped has ended)."""
    out = []
    for p in pids:
        try:
            with open(f"/proc/{p}/stat") as f:
                if f.read().rsplit(")", 1)[1].split()[0] != "Z":
                    out.append(p)
        except (OSError, IndexError):
            pass
    return out


def emulators(pids: set[int]) -> set[int]:
    return {p for p, _, cmd in processes() if p in pids and b"emulate" in cmd.split(b"\0")}


@pytest.mark.parametrize("mode", MODES)
def test_esair_std_run_papaman(mode):
    ep = free_endpoint()

    def deployed():
        return sum(row["state"] in ("running", "ready") for row in components(ep)) == 19
    with std_run("papaman", mode, ep, deployed) as proc:
        robots = emulators(descendants(proc.pid))
        assert len(robots) == 1                         # its own emulated PAPA-MAN
        esair("put", "sequencer", '["stand_up", "dance"]', "-e", ep)
        wait_for(lambda: json.loads(esair("get", "sequencer", "-e", ep).stdout)["done"]
                 == ["stand_up", "dance"], timeout=60, what="two operations played")
    # nothing left behind: the emulator ends with the runtime (its exit is the driver's
    # doing, in an agent process in process mode: the runtime's exit may come first)
    wait_for(lambda: not running(robots), timeout=30, what=f"the emulators {robots} gone")


def test_port_points_the_deployment_at_another_robot(tmp_path):
    trace = tmp_path / "t.txt"
    with EmulatedRobot(ROOT / "boards" / "papaman", ["--trace", str(trace)]) as emu:
        r = esair("run", "papaman", "--run", "2", "--port", emu.port, "--top",
                  "-e", free_endpoint())
        table, _, summary = r.stdout.rpartition("NAME ")
        assert "ESAIR STD — robot papaman" in table and "│   .notices " in table
        assert "│   .servo.* (12) " in table           # the driver's children grouped
        rows = {line.split()[0]: line.split()[2] for line in summary.splitlines()[1:]}
        assert rows["papaman.motion"] == "ready" and rows["papaman.feet"] == "ready"
    # the robot behind --port answered the link's probe and the feet polls
    assert "TX " + b"OK 512,512,512,512,512,512,512,512\r\n".hex().upper() in trace.read_text()


@pytest.mark.parametrize("mode", MODES)
def test_a_feet_rate_beyond_the_line_is_refused(tmp_path, mode):
    text = (EXAMPLE / "papaman.yaml").read_text()
    assert "feet_hz: 8 " in text
    (tmp_path / "fast.yaml").write_text(text.replace("feet_hz: 8 ", "feet_hz: 50"))
    (tmp_path / "papaman_behaviors.py").write_text(
        (EXAMPLE / "papaman_behaviors.py").read_text())
    r = esair("run", str(tmp_path / "fast.yaml"), "--run", "1", "--mode", mode,
              "-e", free_endpoint(), check=False)
    assert (r.returncode, r.stderr) == (
        1, "error: resource 'papaman' failed to open: LinkError: feet poll rate 50 Hz exceeds "
           "the line's budget: at 9600 baud one 's' exchange takes up to 50.7 ms (3 bytes out, "
           "44 back), so 50% of the line allows at most 9.9 Hz\n")
