"""STARFISH's figures across the veth and on one computer (issue 23 item 5), side by side
in one run:

(a) camera pictures 320x240 from the robot (host 0) to a remote agent (host 1) through
    ESAIR STD in process mode, beside raw zenoh puts of the same size between the same
    two namespaces: at 10 a second (delivered, lost, latency: the goal's figure, >= 0.8x)
    and offered at 1000 a second (what each carries at most); the camera's PNG and JPEG
    of the example room (a raw 24-bit picture, 307 KB as base64, is over STD's 256 KiB
    message cap: the camera always encodes);
(b) microphone frames (4 x 1024 int16, the driver's wire format) across the veth with
    the link up: lost of 10 000 (goal 0), sent at --frame-rate (default 200 a second,
    12.8 times the array's 15.625, so 10 000 take 50 s);
(c) zenoh shared memory against plain puts on one computer (two processes, a router and
    a client over loopback TCP): samples a second and latency of 8 KiB, 230 KB and 1 MB
    samples, and whether the subscriber got them as SHM buffers.

Run: sudo python bench/starfish_net.py [--seconds 5] [--frames 10000]. Needs root for the
namespaces (esair_std/netsim.py); prints figures and ratios; asserts nothing.
"""

from __future__ import annotations

import argparse
import json
import struct
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from esair_std import netsim as netns  # noqa: E402

ROOM = ROOT / "esair_std" / "examples" / "starfish" / "room.yaml"
HEADER = struct.Struct("<qd")           # seq, time.time() at the put
RAW_PORT = 7460


def pct(values: list[float], q: float) -> float | None:
    values = sorted(values)
    return values[min(len(values) - 1, int(q * len(values)))] if values else None


# ---- raw zenoh: one publisher, one subscriber (run as this script's sub-commands) ------

def _session(spec: dict):
    import zenoh
    conf = zenoh.Config()
    conf.insert_json5("scouting/multicast/enabled", "false")
    # plain: shared memory off (zenoh would otherwise move large payloads through it on
    # one computer by itself: transport_optimization)
    conf.insert_json5("transport/shared_memory/enabled", "true" if spec.get("shm") else "false")
    if "listen" in spec:
        conf.insert_json5("mode", '"router"')
        conf.insert_json5("listen/endpoints", json.dumps([spec["listen"]]))
    else:
        conf.insert_json5("mode", '"client"')
        conf.insert_json5("connect/endpoints", json.dumps([spec["connect"]]))
    deadline = time.monotonic() + 20
    while True:                       # the other side's listener may not be up yet
        try:
            return zenoh.open(conf)
        except zenoh.ZError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.2)


def raw_pub(spec: dict) -> None:
    """Publish spec["n"] samples of spec["size"] bytes at spec["rate"] a second once a
    subscriber matches; spec["shm"]: from a shared-memory provider."""
    import zenoh
    s = _session(spec)
    pub = s.declare_publisher("bench/raw", congestion_control=zenoh.CongestionControl.BLOCK
                              if spec.get("block") else zenoh.CongestionControl.DROP)
    deadline = time.monotonic() + 30
    while not pub.matching_status.matching and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.5)
    size, n, rate = spec["size"], spec["n"], spec["rate"]
    filler = bytes(size - HEADER.size)
    provider = None
    if spec.get("shm"):
        from zenoh import shm
        provider = shm.ShmProvider.default_backend(max(64 * size, 16 << 20))
        policy = shm.BlockOn(shm.GarbageCollect())
    t0 = time.monotonic()
    for i in range(1, n + 1):
        head = HEADER.pack(i, time.time())
        if provider is not None:
            buf = provider.alloc(size, policy)
            buf[0:HEADER.size] = head
            buf[HEADER.size:size] = filler
            pub.put(buf)
        else:
            pub.put(head + filler)
        wait = t0 + i / rate - time.monotonic()
        if wait > 0:
            time.sleep(wait)
    print(json.dumps({"sent": n, "seconds": time.monotonic() - t0}), flush=True)
    time.sleep(2.0)
    s.close()


def raw_sub(spec: dict) -> None:
    s = _session(spec)
    got = {"count": 0, "last": 0, "lost": 0, "shm": 0, "lat": [], "t_first": None, "t_last": None}
    done = threading.Event()

    def on(sample):
        now = time.time()
        payload = sample.payload
        if payload.as_shm() is not None:
            got["shm"] += 1
        data = payload.to_bytes()                  # the copy a Python user makes anyway
        seq, t = HEADER.unpack_from(data)
        if seq > got["last"] + 1:
            got["lost"] += seq - got["last"] - 1
        got["last"] = seq
        got["count"] += 1
        got["lat"].append(now - t)
        got["t_first"] = got["t_first"] or now
        got["t_last"] = now
        if seq >= spec["n"]:
            done.set()

    sub = s.declare_subscriber("bench/raw", on)
    print(json.dumps({"ready": True}), flush=True)
    done.wait(spec["timeout"])
    time.sleep(0.2)
    sub.undeclare()
    lat = got.pop("lat")
    got.update(p50=pct(lat, 0.5), p99=pct(lat, 0.99))
    if got["last"] < spec["n"]:
        got["lost"] += spec["n"] - got["last"]          # the tail that never came
    print(json.dumps(got), flush=True)
    s.close()


def _run_pair(pub_host, sub_host, spec_pub: dict, spec_sub: dict) -> dict:
    from bench.toolkit.netstd import Proc
    sub = Proc(sub_host, [sys.executable, __file__, "raw-sub", json.dumps(spec_sub)])
    pub = Proc(pub_host, [sys.executable, __file__, "raw-pub", json.dumps(spec_pub)])
    sub.wait_line('"ready"', 30)
    pub.wait_line('"sent"', spec_pub["n"] / spec_pub["rate"] + 60)
    line = sub.wait_line('"count"', spec_sub["timeout"] + 30)
    pub.wait_exit(30)
    sub.wait_exit(30)
    return json.loads(line)


class _Local:
    """The computer itself as a host of _run_pair (part c: one computer, no namespace)."""

    def popen(self, *cmd, **kw):
        return subprocess.Popen(list(cmd), start_new_session=True, **kw)


# ---- ESAIR STD across the veth ------------------------------------------------------------

CENTER = """
robot: starfish
mode: process
endpoint: ENDPOINT
resources:
  cam: {class: "starfish_net_comps:Pictures", room_file: ROOM, kind: KIND, rate: RATE,
        allow: {"*": read}}
  mics: {class: "starfish_net_comps:Frames", rate: FRATE, allow: {"*": read}}
"""


def std_stream(net, base: Path, sensor: str, kind: str, rate: float, n: int,
               frame_rate: float) -> dict:
    """The sensor's samples received by a remote agent (host 1) from the control center
    (host 0), until n of them were sent."""
    from bench.toolkit.netstd import Center, agent
    folder = base / f"{sensor}-{kind}-{rate:g}"
    folder.mkdir()
    (folder / "starfish_net_comps.py").write_text((ROOT / "bench" / "starfish_net_comps.py").read_text())
    dep = (CENTER.replace("ROOM", str(ROOM)).replace("KIND", kind)
           .replace("FRATE", str(frame_rate if sensor == "mics" else 0.001))
           .replace("RATE", str(rate if sensor == "cam" else 0.001)))
    center = Center(net[0], folder, dep)
    a = agent(net[1], center.endpoint, "count", "starfish_net_comps:Count", "--robot",
              center.robot, "--uses", f"{sensor}=read", "-o", f"sensor={sensor}",
              "--period", "0.005", cwd=folder)
    netns.wait_for(lambda: center.state("count") == "running", 60, interval=0.3,
                   what="the remote agent running")
    want = rate if sensor == "cam" else frame_rate

    def counted():
        try:
            g = center.get("count")
        except (AssertionError, ValueError):
            return None
        return g if g["count"] and g["last"] - g["first"] + 1 >= n else None
    got = netns.wait_for(counted, n / want + 60, interval=0.5, what=f"{n} samples of {sensor}")
    got["expected"] = got["last"] - got["first"] + 1
    for proc in (a, center.run):
        proc.proc.terminate()
        try:
            proc.wait_exit(30)
        except subprocess.TimeoutExpired:      # a loaded machine: do not wait for ever
            proc.proc.kill()
            proc.wait_exit(30)
    return got


def picture_size(kind: str) -> int:
    """The JSON size of one picture sample as the sensor reports it (its value)."""
    sys.path.insert(0, str(ROOT / "bench"))
    import starfish_net_comps as comps
    p = comps.Pictures()
    p._esair = type("S", (), {"options": {"room_file": str(ROOM), "kind": kind}, "name": "cam"})()
    p.open()
    return len(json.dumps(p.read()))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=float, default=5.0, help="each picture stream's length")
    ap.add_argument("--frames", type=int, default=10000)
    ap.add_argument("--frame-rate", type=float, default=200.0)
    ap.add_argument("--skip", default="", help="parts to skip: a, b, c")
    args = ap.parse_args()
    if "c" not in args.skip:
        shm_part()
    if {"a", "b"} <= set(args.skip):
        return
    why = netns.unavailable()
    if why:
        raise SystemExit(f"bench/starfish_net.py: {why}")
    with tempfile.TemporaryDirectory() as tmp, netns.Net(2) as net:
        base = Path(tmp)
        if "a" not in args.skip:
            print("(a) pictures 320x240, robot (host 0) -> remote (host 1) across the veth, "
                  "process mode")
            for kind in ("png", "jpeg"):
                size = picture_size(kind)
                for rate in (10.0, 1000.0):
                    n = int(rate * args.seconds)
                    std = std_stream(net, base, "cam", kind, rate, n, 0.001)
                    spec = {"size": size, "n": n, "rate": rate}
                    raw = _run_pair(net[0], net[1],
                                    {**spec, "connect": f"tcp/{net[1].addr}:{RAW_PORT}"},
                                    {**spec, "listen": f"tcp/{net[1].addr}:{RAW_PORT}",
                                     "timeout": n / rate + 30})
                    print(_line(kind, size, rate, std, raw), flush=True)
        if "b" not in args.skip:
            got = std_stream(net, base, "mics", "png", 0.001, args.frames, args.frame_rate)
            lost = got["expected"] - got["count"]
            print(f"(b) microphone frames across the veth, link up, {args.frame_rate:g}/s: "
                  f"{lost} lost of {got['expected']} (holes by seq {got['lost']}, the "
                  f"behavior's queue overwrote {got['overwritten']}); latency p50 "
                  f"{got['p50'] * 1e3:.1f} ms p99 {got['p99'] * 1e3:.1f} ms   (goal 0 of 10 000)")


def _rate(g: dict) -> float:
    span = (g["t_last"] or 0) - (g["t_first"] or 0)
    return (g["count"] - 1) / span if span > 0 else 0.0


def _line(kind: str, size: int, rate: float, std: dict, raw: dict) -> str:
    sr, rr = _rate(std), _rate(raw)
    std_lost = std["expected"] - std["count"]
    return (f"   {kind} {size / 1024:.1f} KiB offered {rate:g}/s: STD {sr:.1f}/s "
            f"({std['count']} got, {std_lost} lost, p50 {std['p50'] * 1e3:.1f} ms p99 "
            f"{std['p99'] * 1e3:.1f} ms) vs raw zenoh {rr:.1f}/s ({raw['count']} got, "
            f"{raw['lost']} lost, p50 {(raw['p50'] or 0) * 1e3:.1f} ms p99 "
            f"{(raw['p99'] or 0) * 1e3:.1f} ms): {sr / rr if rr else float('nan'):.2f}x "
            f"(goal >= 0.8x)")


def shm_part() -> None:
    print("(c) zenoh shared memory vs plain puts, one computer (client publisher, router subscriber over "
          "loopback TCP, two processes), offered 2000/s for 2 s, congestion control BLOCK")
    import socket
    for size in (8 * 1024, 320 * 240 * 3, 1 << 20):
        out = {}
        for shm in (False, True):
            with socket.socket() as sk:
                sk.bind(("127.0.0.1", 0))
                port = sk.getsockname()[1]
            spec = {"size": size, "n": 4000, "rate": 2000.0, "shm": shm, "block": True}
            out[shm] = _run_pair(_Local(), _Local(), {**spec, "connect": f"tcp/127.0.0.1:{port}"},
                                 {**spec, "listen": f"tcp/127.0.0.1:{port}", "timeout": 60})
        p, s = out[False], out[True]
        print(f"   {size / 1024:7.1f} KiB: plain {_rate(p):7.0f}/s p50 {p['p50'] * 1e3:6.2f} ms "
              f"| SHM {_rate(s):7.0f}/s p50 {s['p50'] * 1e3:6.2f} ms ({s['shm']} of "
              f"{s['count']} as SHM buffers): SHM/plain {_rate(s) / _rate(p):.2f}x samples/s, "
              f"{s['p50'] / p['p50']:.2f}x latency", flush=True)


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] in ("raw-pub", "raw-sub"):
        (raw_pub if sys.argv[1] == "raw-pub" else raw_sub)(json.loads(sys.argv[2]))
    else:
        main()
