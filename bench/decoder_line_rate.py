"""Python decoder throughput as a multiple of the 115200-baud line rate (issue 3).

Feeds a realistic mix (every kind of PAPA-MAN command, some with checksums, about 10 %
garbage and overlong lines) byte by byte into a CentralCore whose I2C goes to a null
bus, ticking whenever an actuator write is held. Prints the rate, its multiple of
11,520 B/s, and, measured in the same run on the same bytes, a naive ``bytes.split``
line splitter as a baseline ratio. Never asserts wall-clock time.

    python bench/decoder_line_rate.py [--bytes N] [--repeat R]
"""

from __future__ import annotations

import argparse
import random
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from esair_min.core.central import CentralCore
from esair_min.core.devices import NullBus
from esair_min.core.protocol import (add_checksum, encode_angles, encode_motor,
                                encode_play, encode_speeds)
from esair_min.model.validate import load_robot

LINE_RATE = 115200 // 10       # bytes per second at 115200 baud, 8N1


def command_mix(robot, size: int, seed: int = 1) -> bytes:
    rnd = random.Random(seed)
    servos = robot.servos
    n = len(servos)
    out = bytearray()
    while len(out) < size:
        r = rnd.random()
        if r < 0.05:                                   # overlong line
            line = bytes(rnd.choice(b"abcdefghijklmnop0123456789") for _ in range(rnd.randint(41, 80)))
        elif r < 0.10:                                 # garbage, any bytes
            line = bytes(rnd.randrange(256) for _ in range(rnd.randint(1, 30)))
        else:
            kind = rnd.randrange(9)
            if kind == 0:
                text = "t"
            elif kind == 1:
                m = rnd.randrange(n)
                text = encode_motor(m, rnd.randint(0, 25),
                                    rnd.randint(servos[m].min_angle, servos[m].max_angle))
            elif kind == 2:
                text = encode_play(rnd.randint(0, 6))
            elif kind == 3:
                text = encode_speeds([rnd.randint(0, 25) for _ in range(n)])
            elif kind == 4:
                text = encode_angles([None if rnd.random() < 0.3 else
                                      3 * rnd.randint(-(-s.min_angle // 3), s.max_angle // 3)
                                      for s in servos])
            else:
                text = rnd.choice(["v", "s", "x", "SIT", "DNC"])
            if rnd.random() < 0.3:
                text = add_checksum(text)
            line = text.encode()
        out += line + rnd.choice([b"\r\n", b"\n", b"\r"])
    return bytes(out)


def run_decoder(robot, data: bytes) -> tuple[float, int]:
    replies = 0

    def send(line: bytes) -> None:
        nonlocal replies
        replies += 1

    core = CentralCore(robot, NullBus(), send)
    core.boot()
    rx, ready, tick = core.rx_byte, core.ready, core.tick
    t0 = time.perf_counter()
    for b in data:
        if not ready():
            tick()
        rx(b)
    tick()
    return time.perf_counter() - t0, replies


def run_baseline(data: bytes) -> tuple[float, int]:
    t0 = time.perf_counter()
    lines = [line.rstrip(b"\r") for line in data.replace(b"\r\n", b"\n").split(b"\n")]
    count = sum(1 for line in lines if line)
    return time.perf_counter() - t0, count


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bytes", type=int, default=300_000)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    robot = load_robot(Path(__file__).resolve().parents[1] / "boards" / "papaman")
    data = command_mix(robot, args.bytes)
    best = min(run_decoder(robot, data)[0] for _ in range(args.repeat))
    base = min(run_baseline(data)[0] for _ in range(args.repeat))
    _, replies = run_decoder(robot, data)
    rate = len(data) / best
    print(f"input: {len(data)} bytes, {replies} reply lines (mix with ~10 % garbage/overlong)")
    print(f"decoder (CentralCore.rx_byte, byte at a time): {rate / 1e6:.2f} MB/s = "
          f"{rate / LINE_RATE:.0f}x the 115200-baud line rate ({LINE_RATE} B/s)")
    print(f"baseline (bytes.split line splitter, no decoding): "
          f"{len(data) / base / 1e6:.1f} MB/s; decoder/baseline = {base / best:.3f}")
    print(f"goal >= 100x line rate: {'met' if rate / LINE_RATE >= 100 else 'NOT met'}")


if __name__ == "__main__":
    main()
