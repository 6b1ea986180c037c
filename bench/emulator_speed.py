"""Emulator benchmark: simulated seconds per wall second, and the bus-time ratios.

1. PAPA-MAN dancing headless in virtual time: the host keeps the serial line busy at
   line rate with a mix of commands (PLY03 restarts the dance whenever it has ended,
   oab100, s, and two 39-character speeds lines: more bytes in than out, so the board
   keeps up without overruns), the balance reaction polls the sensor
   board every 5 ticks. Prints simulated seconds per wall second and per CPU second
   (the machine may be shared), median of several runs, side by side with baselines
   run in the same process: real time (1x, what a person at the serial port needs),
   the same run with the event trace formatted (streamed nowhere), and with the UART
   fast paths off (every received byte landing in the ring at its own time).
2. On the same I2C bus model (TimedBus over the emulated devices, 100 kHz): bus time of
   one frame update written as one burst vs the thesis's two 3-byte transactions per
   servo, and the EEPROM read of one frame as one sequential read vs the thesis's
   per-byte random reads each followed by a 6 ms delay.

Run: python bench/emulator_speed.py [--seconds 60] [--repeat 5]. Prints ratios; asserts
nothing.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from esair_min.core.devices import Eeprom24, RegisterSlave, SimpleBus  # noqa: E402
from esair_min.emulator import Emulator  # noqa: E402
from esair_min.emulator.clock import NS_PER_S  # noqa: E402
from esair_min.emulator.i2c import TimedBus  # noqa: E402
from esair_min.core.image import build_image  # noqa: E402
from esair_min.core.trace import TraceWriter  # noqa: E402
from esair_min.model.validate import load_robot  # noqa: E402

# 96 bytes in, about 75 bytes of replies out: a load the board sustains (with replies
# longer than the lines, its transmit ring fills and its receive ring overruns)
MIX = [b"PLY03\r\n", b"oab100\r\n", b"s\r\n", b"a" + b"002" * 12 + b"\r\n",
       b"a" + b"001" * 12 + b"\r\n"]
THESIS_DELAY_S = 0.006


def dancing(robot, seconds: float, trace: bool = False, fast: bool = True) -> dict:
    emu = Emulator(robot, scenario="quiet", trace=TraceWriter(keep=False) if trace else None)
    if not fast:
        emu.uart._rx_mode = None          # byte by byte through the ring (the slow path)
    emu.settle()
    state = {"i": 0, "out": 0}
    batch = b"".join(MIX)
    ahead_ns = 50_000_000        # keep 50 ms of bytes queued on the line: never idle

    def top_up() -> None:
        while emu.uart.rx_free_ns - emu.clock.now < ahead_ns:
            emu.write(batch)
        state["out"] += len(emu.read())
        emu.clock.after(10_000_000, top_up)

    top_up()
    frames0 = emu.bus.stats.by_address.get(0x10, 0)
    t0, c0 = time.perf_counter(), time.process_time()
    emu.run_for(seconds)
    wall = time.perf_counter() - t0
    cpu = time.process_time() - c0
    state["out"] += len(emu.read())
    busy_ticks = emu.bus.stats.bits / robot.central.i2c.speed_hz
    return {
        "wall": wall, "cpu": cpu, "sim": seconds, "ticks": emu.ticks, "rx": emu.uart.rx_bytes,
        "tx": state["out"], "replies": emu.replies.count, "overruns": emu.uart.overruns,
        "actuator_bits": emu.bus.stats.by_address.get(0x10, 0) - frames0,
        "bus_load": busy_ticks / (emu.clock.now / NS_PER_S),
        "backlog_s": max(0, emu.uart._tx_free - emu.clock.now) / NS_PER_S,
    }


def bus_model(robot) -> dict:
    central = robot.central
    eep, act = robot.eeprom, robot.peer("actuator")
    n = len(robot.servos)
    now = [0]
    eeprom = Eeprom24(eep.size_bytes, eep.address, eep.address_bytes, build_image(robot))
    slave = RegisterSlave(act.address, act.registers)
    bus = TimedBus(SimpleBus([eeprom, slave]), central.i2c.speed_hz, lambda: now[0])
    frame_at = robot.layout.slots[3].offset
    abytes = eep.address_bytes

    def timed(fn) -> float:
        start = bus.busy_until
        fn()
        return (bus.busy_until - start) / NS_PER_S

    frame = eeprom.memory[frame_at:frame_at + 2 * n]
    burst = timed(lambda: bus.write(act.address, bytes([0]) + frame))

    def thesis_write() -> None:
        for m in range(n):
            bus.write(act.address, bytes([2 * m, frame[2 * m]]))
            bus.write(act.address, bytes([2 * m + 1, frame[2 * m + 1]]))

    per_servo = timed(thesis_write)
    seq = timed(lambda: bus.write_read(eep.address, frame_at.to_bytes(abytes, "big"), 2 * n))

    def thesis_read() -> None:
        for k in range(2 * n):
            bus.write_read(eep.address, (frame_at + k).to_bytes(abytes, "big"), 1)
            bus.busy_until += int(THESIS_DELAY_S * NS_PER_S)     # delay_ms(6), bus idle

    per_byte = timed(thesis_read)
    return {"burst": burst, "per_servo": per_servo, "seq": seq, "per_byte": per_byte,
            "tick": central.timer2.period_s, "speed": central.i2c.speed_hz, "n": n}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0, help="simulated seconds")
    ap.add_argument("--repeat", type=int, default=5, help="runs (the median is printed)")
    args = ap.parse_args()
    robot = load_robot(ROOT / "boards" / "papaman")

    variants = [("emulator, no trace", {}),
                ("emulator, trace formatted", {"trace": True}),
                ("UART fast paths off", {"fast": False})]
    runs: dict[str, list[dict]] = {name: [] for name, _ in variants}
    for _ in range(args.repeat):                 # interleaved: load hits every variant
        for name, kw in variants:
            runs[name].append(dancing(robot, args.seconds, **kw))

    def rates(name: str) -> tuple[float, float]:
        rs = runs[name]
        return (statistics.median(r["sim"] / r["wall"] for r in rs),
                statistics.median(r["sim"] / r["cpu"] for r in rs))

    d = runs[variants[0][0]][0]
    print(f"PAPA-MAN dancing, balance polling, commands at line rate "
          f"({robot.central.uart.baud} baud), headless; {args.seconds:g} simulated s per "
          f"run, median of {args.repeat} runs:")
    print(f"  {'':28s} {'per wall s':>11s} {'per CPU s':>10s}")
    print(f"  {'real time (the need)':28s} {1:10.0f}x {1:9.0f}x")
    print(f"  {'goal':28s} {200:10.0f}x {200:9.0f}x")
    for name, _ in variants:
        w, c = rates(name)
        print(f"  {name:28s} {w:10.0f}x {c:9.0f}x")
    (w0, c0), (w1, c1), (w2, c2) = (rates(name) for name, _ in variants)
    print(f"  no trace vs trace formatted: {w0 / w1:.2f}x wall, {c0 / c1:.2f}x CPU; "
          f"fast paths vs byte by byte: {w0 / w2:.2f}x wall, {c0 / c2:.2f}x CPU; "
          f"margin over the goal (CPU): {c0 / 200:.1f}x")
    print(f"  {d['ticks']} ticks, {d['rx']} bytes in, {d['tx']} bytes out, "
          f"{d['replies']} lines sent, {d['overruns']} overruns, "
          f"I2C bus busy {d['bus_load']:.0%} of the time, "
          f"reply backlog at the end {d['backlog_s'] * 1e3:.0f} ms")

    b = bus_model(robot)
    ms = 1e3
    print(f"One frame of {b['n']} servos on the I2C bus model at {b['speed'] // 1000} kHz "
          f"(tick {b['tick'] * ms:.4g} ms):")
    print(f"  write: one burst {b['burst'] * ms:.2f} ms vs thesis 2 x 3-byte transactions "
          f"per servo {b['per_servo'] * ms:.2f} ms: {b['per_servo'] / b['burst']:.2f}x")
    print(f"  EEPROM read: one sequential read {b['seq'] * ms:.2f} ms vs thesis per-byte "
          f"reads + 6 ms delays {b['per_byte'] * ms:.1f} ms: {b['per_byte'] / b['seq']:.1f}x")
    ours, theirs = b["burst"] + b["seq"], b["per_servo"] + b["per_byte"]
    print(f"  frame update (read + write): {ours * ms:.2f} ms = {ours / b['tick']:.0%} of a "
          f"tick vs thesis {theirs * ms:.1f} ms = {theirs / b['tick']:.1f} ticks: "
          f"{theirs / ours:.1f}x")


if __name__ == "__main__":
    main()
