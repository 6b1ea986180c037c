"""The latched STOP's latency (issue 34 item 1): from the click to the robot's last
actuator write, PAPA-MAN emulated behind a real pty at its own 9600 baud.

Each round the operator plays the dance (a frame every 9 ms tick), waits DANCE_WAIT_S
(the dance is then playing), STOPs, and releases. Two figures per STOP:

- click -> x on the robot: from just before the STOP's call (time.time()) to when the
  robot had the whole ``x`` line: the ``at`` of the STOP's command record (written, plus
  the line's time on the wire: drivers/minlink/driver.py), on the host's clock;
- click -> last actuator write: that, less how long before the ``x`` the robot's last
  write came (the robot's own trace, ``--trace-rx``: the virtual time of its ``RX x``
  line less that of the last ``W 10`` before it). The robot writes nothing after the
  ``x`` (tests/std/test_std_stop.py holds that).

Goal: p99 <= one frame tick + the line's time for ``x`` (8.99 + 3.13 = 12.1 ms).

The paths: ``api`` Runtime.stop_robot() in the runtime's process (thread mode); ``ctl``
the control request ``esair std stop`` sends (from this process: the command's
interpreter start left out), thread and process mode; ``hmi`` the page's STOP frame on
the HMI's WebSocket (``esair std hmi`` in its own process), thread mode.

Run: python bench/std_stop.py [--rounds 30] [--paths api,ctl,ctl-process,hmi]
Prints figures; asserts nothing.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "bench")]

from esair_std import Runtime  # noqa: E402
from esair_std.cli.client import Client  # noqa: E402
from esair_std.drivers.minlink.emulated import EmulatedRobot  # noqa: E402
from esair_std.transport import keys, records  # noqa: E402
from esair_std.transport.bus import Bus  # noqa: E402
from toolkit import free_port  # noqa: E402

PAPAMAN = ROOT / "boards" / "papaman"
DANCE_WAIT_S = 0.12        # the dance (32 frames, one a tick) is playing then
TICK_MS = 8.9856
X_LINE_MS = 3 * 10 / 9600 * 1000


def deployment(port: str) -> dict:
    return {"robot": "papaman", "mode": "thread", "resources": {"papaman": {
        "class": "esair_std.drivers.minlink:MinLink", "robot": "papaman", "port": port,
        "feet_hz": 8, "allow": {"*": "read", "operator": "command", "hmi": "command"}}}}


class StopRecords:
    """The ``at`` of each command record "stop" of papaman.motion, as they come."""

    def __init__(self, bus, robot: str):
        self.at: list[float] = []
        self.cond = threading.Condition()
        bus.subscribe(keys.commands_all(robot), self._on, with_key=True)

    def _on(self, key: str, obj) -> None:
        got, _bad = records.unpack(key, obj)
        for res, rec in got:
            v = rec["v"]
            if res == "papaman.motion" and v.get("command") == "stop" and "ok" in v:
                with self.cond:
                    self.at.append(float(v["ok"]["at"]))
                    self.cond.notify_all()

    def wait(self, n: int, timeout: float = 5.0) -> float:
        with self.cond:
            if not self.cond.wait_for(lambda: len(self.at) >= n, timeout):
                raise RuntimeError("no record of the STOP")
            return self.at[n - 1]


def before_x(trace: Path) -> list[float]:
    """For each ``x`` the robot received: ms from its last actuator write to the x."""
    out, mark, last_w = [], 0, None
    for line in trace.read_text().splitlines():
        if line.startswith("@ "):
            mark = int(line[2:])
        elif line.startswith("W 10 ") and line.endswith(" ACK"):
            last_w = mark
        elif line == "RX 780D" and last_w is not None:
            out.append((mark - last_w) / 1000)
            last_w = None
    return out


def run_path(path: str, rounds: int) -> dict:
    mode = "process" if path.endswith("-process") else "thread"
    tmp = Path(tempfile.mkdtemp(prefix="esair-stop-bench-"))
    trace = tmp / "trace.txt"
    emu = EmulatedRobot(PAPAMAN, ["--trace", str(trace), "--trace-rx"])
    emu.start()
    ep = f"tcp/127.0.0.1:{free_port()}"
    rt = Runtime(deployment(emu.port), mode=mode, endpoint=ep, control=True)
    rt.start()
    hmi = ws = None
    client = Client(ep)
    # the records come from the resource's own process in process mode: a session that
    # dials the peers the runtime names (as the HMI's), not the client's runtime-only one
    listen = Bus(connect=[ep], runtime=ep)
    try:
        recs = StopRecords(listen, "papaman")
        stop = {"api": lambda: rt.stop_robot("bench"),
                "ctl": lambda: client.call("stop", {"reason": "bench"})}.get(path.split("-")[0])
        if path == "hmi":
            from websockets.sync.client import connect
            hmi = subprocess.Popen([sys.executable, "-m", "esair_min.cli", "std", "hmi", "-e", ep,
                                    "--listen", "127.0.0.1:0"], stdout=subprocess.PIPE,
                                   stderr=subprocess.DEVNULL, text=True, cwd=tmp,
                                   env=dict(os.environ, PYTHONPATH=str(ROOT)))
            url = hmi.stdout.readline().strip()
            ws = connect(url.replace("http", "ws", 1) + "ws", origin=url.rstrip("/"),
                         legacy=True)
            ws.recv()                                           # hello

            def stop() -> None:
                ws.send(json.dumps({"op": "stop", "id": 1}))
                while json.loads(ws.recv()).get("t") != "ack":
                    pass
        to_x = []
        for i in range(rounds):
            client.call("send", {"name": "papaman.motion", "value": {"play": "dance"}})
            time.sleep(DANCE_WAIT_S)
            t0 = time.time()
            stop()
            to_x.append((recs.wait(i + 1) - t0) * 1000)
            client.call("release", {})
            time.sleep(0.05)
    finally:
        if ws is not None:
            ws.close()
        if hmi is not None:
            hmi.terminate()
            hmi.wait(10)
        client.close()
        listen.close()
        rt.stop()
        emu.stop()
    gap = before_x(trace)[-rounds:]
    last = [a - b for a, b in zip(to_x, gap)]
    return {"x": to_x[1:], "last": last[1:], "first": (to_x[0], last[0])}


def pct(xs: list[float], p: float) -> float:
    s = sorted(xs)
    return s[min(len(s) - 1, int(round(p / 100 * (len(s) - 1))))]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=30)
    ap.add_argument("--paths", default="api,ctl,ctl-process,hmi")
    a = ap.parse_args()
    load = os.getloadavg()[0]
    goal = TICK_MS + X_LINE_MS
    print(f"STOP latency, {a.rounds} STOPs a path (load {load:.1f}); goal p99 <= {goal:.1f} ms")
    print("(the first STOP of a run apart: its path is then taken for the first time)")
    print(f"{'path':<12} {'click -> x on the robot p50 / p99':>34}   "
          f"{'click -> last actuator write p50 / p99':>40}   first STOP: x / last write")
    for path in a.paths.split(","):
        r = run_path(path, a.rounds + 1)
        print(f"{path:<12} {statistics.median(r['x']):>24.1f} / {pct(r['x'], 99):>6.1f} ms   "
              f"{statistics.median(r['last']):>30.1f} / {pct(r['last'], 99):>6.1f} ms"
              f"   {'met' if pct(r['last'], 99) <= goal else 'missed'}"
              f"   {r['first'][0]:.1f} / {r['first'][1]:.1f} ms")


if __name__ == "__main__":
    main()
