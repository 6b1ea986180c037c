"""STARFISH's boards on the ATmega328P in simavr, against the Python cores.

The central board (:func:`run_central`): the same stimulus scripts as the gpsim
harness (esair_min/pic/starfish_gpsim.py) -- ``rx TEXT``, ``raw HH ...``, ``tick N``,
``floor S 0|1`` -- and ``flow S DX DY SQUAL`` (sensor S's next deltas, cleared when
read, and its surface quality). simavr runs the firmware; the driver (simdrv.c) sends
each byte at line rate on USART0 (the board's exact UBRR0 rate), holds the drive board
on the TWI (a modelled register slave, or the drive board's own firmware as node 1:
:func:`run_robot`) and models each ADNS-2610-class sensor on its two bit-banged pins
(it samples the address on SCLK's rising edges, drives the data bits from the falling
ones, and reports a read sooner than tSRAD after the address). The Python core is then
fed the same events in the same order (esair_min/components/omni_base/sim_replay.py): each
byte at the cycle the receive interrupt took it, each tick at Timer1's compare
interrupt, each sensor change at its cycle.

The drive board (:func:`run_drive`): the central's writes put straight into the TWI
slave's register map (``regs``) at a fixed phase between control ticks, as
esair_min/pic/starfish_drive.py does in gpsim; after each step the driver reads what
drives the motors -- OCR0A/OCR0B/OCR1AL/OCR1BL (the duty itself: phase-correct 8-bit
PWM), the software duties and the direction port bits -- and the timer interrupt's
cycles (vector to RETI) are counted over :data:`ISR_SPANS` interrupts.
"""

from __future__ import annotations

import re
import subprocess
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

from esair_min.avr.simavr_harness import AvrRun, SimError, parse_events, run_commands, symbol, symbols
from esair_min.components.dc_motor import DcMotor, motor_units
from esair_min.components.dc_motor.core import CONTROL_TICK_MS, DriveCore, from_s16
from esair_min.components.omni_base.sim_replay import FlowChange, Run, replay, reply_lines
from esair_min.components.optical_flow.core import REG_DELTA_X, REG_DELTA_Y, REG_SQUAL, T_SRAD_NS
from esair_min.core.script import unescape
from esair_min.errors import ProtocolError
from esair_min.model import avr
from esair_min.model.mcu import McuSpec
from esair_min.model.robot import Robot
from esair_min.pic.starfish_drive import MotorOut
from esair_min.pic.starfish_gpsim import CentralCycles

BOOT_CYCLES = 40_000      # reset, avr-libc's start-up, hal_init, core_init: well inside
SERVED = 25_000           # cycles: a tick this long before the end has been served (a
                          # core_tick with two sensors' six reads takes ~13 000)
DRAIN_TICKS = 10          # after the last line: the replies leave the transmit ring
MARGIN = 500              # cycles: a line end this close to a tick is refused
TIMER1_COMPA = 11         # the ATmega328P's interrupt vector numbers
TIMER2_COMPA = 7
ISR_SPANS = 230
WINDOW_PERIODS = 4             # software PWM periods (64 interrupts each) whose pins are timed
#: data-space addresses of what drives a motor: OCRnx per hardware unit, the ports
OCR = {"oc0a": 0x47, "oc0b": 0x48, "oc1a": 0x88, "oc1b": 0x8A}
PORT = {"B": 0x25, "C": 0x28, "D": 0x2B}


@dataclass(frozen=True)
class CentralSetup:
    clock_hz: int
    tick_cycles: int
    byte_cycles: int
    drive_address: int
    drive_registers: int
    flow_pins: tuple[tuple[str, str], ...]     # (SCLK, SDIO) driver pin names per sensor

    @classmethod
    def from_robot(cls, robot: Robot) -> CentralSetup:
        c, drive = robot.central, robot.board("drive")
        tick, baud = c.timer2, c.baud
        if (not isinstance(tick, avr.Timer1Tick) or not isinstance(baud, avr.UsartBaud)
                or drive is None or drive.i2c.address is None):
            raise SimError("STARFISH's simavr harness needs an atmega328p central board with "
                           "uart: and tick:, and a drive board")
        bit = (baud.ubrr + 1) * (8 if baud.u2x else 16)
        return cls(c.mcu.clock_hz, tick.cycles, 10 * bit, drive.i2c.address,
                   drive.register_count,
                   tuple((f.sclk_pin[1:], f.sdio_pin[1:]) for f in c.flow_sensors))

    @property
    def srad_cycles(self) -> int:
        return -(-T_SRAD_NS * self.clock_hz // 1_000_000_000)


class _Script:
    """The driver commands of a stimulus, and the flow sensor changes it makes."""

    def __init__(self, s: CentralSetup):
        self.s = s
        self.now = BOOT_CYCLES
        self.rx_free = BOOT_CYCLES
        self.lines = [f"run {BOOT_CYCLES}"]
        self.changes: list[FlowChange] = []

    def send(self, data: bytes) -> None:
        t = max(self.now, self.rx_free)
        for b in data:
            t += self.s.byte_cycles
            self.lines.append(f"rx {t} {b}")
        self.rx_free = t

    def run(self, ticks: int) -> None:
        self.now += ticks * self.s.tick_cycles
        self.lines.append(f"run {self.now}")

    def sensor(self, args: list[str]) -> int:
        n = int(args[0])
        if not 0 <= n < len(self.s.flow_pins):
            raise ProtocolError(f"flow sensor {n}: there are {len(self.s.flow_pins)} flow sensors")
        return n


def _raw(sc: _Script, args: list[str]) -> bool:
    if not args:
        return False
    sc.send(bytes(int(a, 16) for a in args))
    return True


def _tick(sc: _Script, args: list[str]) -> bool:
    if len(args) != 1 or int(args[0]) <= 0:
        return False
    sc.run(int(args[0]))
    return True


def _floor(sc: _Script, args: list[str]) -> bool:
    if len(args) != 2 or args[1] not in ("0", "1"):
        return False
    n = sc.sensor(args)
    sc.changes.append(FlowChange(sc.now, n, floor=int(args[1])))
    sc.lines.append(f"flowfloor {n} {args[1]}")
    return True


def _flow(sc: _Script, args: list[str]) -> bool:
    if len(args) != 4:
        return False
    n = sc.sensor(args)
    dx, dy, q = (int(a) for a in args[1:])
    if not (-128 <= dx <= 127 and -128 <= dy <= 127 and 0 <= q <= 255):
        return False
    sc.changes.append(FlowChange(sc.now, n, motion=(dx, dy, q)))
    sc.lines += [f"flowfloor {n} -1", f"flowreg {n} {REG_DELTA_X} {dx & 0xFF}",
                 f"flowreg {n} {REG_DELTA_Y} {dy & 0xFF}", f"flowreg {n} {REG_SQUAL} {q}"]
    return True


_VERBS = {"raw": _raw, "tick": _tick, "floor": _floor, "flow": _flow}


def script_commands(s: CentralSetup, stimulus: str) -> tuple[list[str], list[FlowChange], int]:
    """The driver commands after the node lines, the flow changes, the end cycle."""
    sc = _Script(s)
    for number, text in enumerate(stimulus.splitlines(), start=1):
        if text.startswith("rx ") or text == "rx":
            sc.send(unescape(text[3:]) + b"\r\n")
            continue
        words = text.split("#", 1)[0].split()
        if not words:
            continue
        verb = _VERBS.get(words[0])
        try:
            ok = verb is not None and verb(sc, words[1:])
        except ValueError:
            ok = False
        except ProtocolError as exc:
            raise ProtocolError(f"stimulus line {number}: {exc.message}") from None
        if not ok:
            raise ProtocolError(f"stimulus line {number}: {text!r} is not rx TEXT, raw HH ..., "
                                "tick N, floor S 0|1 or flow S DX DY SQUAL")
    sc.run(DRAIN_TICKS)
    return sc.lines, sc.changes, sc.now


@dataclass
class CentralRun:
    run: Run                               # what the firmware did
    rx: list[tuple[int, int]]              # (cycle, byte) taken by the receive interrupt
    ticks: list[int]                       # Timer1 compare interrupts, served before the end
    changes: list[FlowChange]
    flow_errors: list[str]                 # reads sooner than tSRAD after the address
    end: int
    sim: AvrRun
    wheels: list[list[MotorOut]]           # run_robot: the drive board's after each step


def _flow_lines(out: str, n: int) -> tuple[list[list[str]], list[str]]:
    reads: list[list[str]] = [[] for _ in range(n)]
    errors = []
    for line in out.splitlines():
        w = line.split()
        if w and w[0] == "flow" and w[1] == "0":
            reads[int(w[2])].append(f"{int(w[4]):02X} {int(w[5]):02X}")
        elif w and w[0] == "flowerr":
            errors.append(f"sensor {w[2]} at cycle {w[3]}")
    return reads, errors


def run_central(robot: Robot, stimulus: str, elf: Path, drive_elf: Path | None = None,
                timeout: float = 300.0) -> CentralRun:
    """Run ``stimulus`` on the central firmware ``elf``; the drive board is a modelled
    register slave, or (``drive_elf``) its firmware as node 1 on the same TWI bus, whose
    motor outputs are read after the boot, every ``tick`` line and the final drain
    (CentralRun.wheels)."""
    s = CentralSetup.from_robot(robot)
    body, changes, end = script_commands(s, stimulus)
    probes = _probes(robot, drive_elf) if drive_elf is not None else []
    if probes:
        body = [x for line in body
                for x in ([line, *_peeks(1, probes)] if line.startswith("run ") else [line])]
    head = [f"flow 0 {i} {sclk} {sdio} {s.srad_cycles}" for i, (sclk, sdio) in enumerate(s.flow_pins)]
    head.append("isrs 0")
    nodes: tuple[str, ...] = ()
    if drive_elf is None:
        head.insert(0, f"regs {s.drive_address} {s.drive_registers}")
    else:
        nodes = (f"node {drive_elf} -",)
    out = run_commands(elf, head + body + ["quit"], "-", timeout, nodes)
    sim = parse_events(out, 0)
    runs = Run(replies=reply_lines(bytes(b for _, b in sim.tx)))
    runs.writes = [t.trace_line() for t in sim.transfers if t.segments and t.stop is not None]
    runs.flow, errors = _flow_lines(out, len(s.flow_pins))
    ticks = [c for c, v in sim.isrs.get(0, []) if v == TIMER1_COMPA and c <= end - SERVED]
    return CentralRun(runs, sim.rx, ticks, changes, errors, end, sim,
                      _motor_outs(out, 1, probes) if probes else [])


def differential(robot: Robot, stimulus: str, elf: Path) -> tuple[Run, CentralRun]:
    """(Python, simavr) runs of ``stimulus``."""
    got = run_central(robot, stimulus, elf)
    return replay(robot, got.rx, got.ticks, got.changes, MARGIN), got


# -- the drive board ------------------------------------------------------------------


@dataclass(frozen=True)
class DriveRun:
    steps: list[list[MotorOut]]        # after each step, per motor
    isr_cycles: Counter[int]           # Timer2 interrupt, vector to RETI, over ISR_SPANS
    #: software PWM pins (driver names): cycles high over the last step's final
    #: WINDOW_PERIODS software PWM periods (simavr drives no pin of a hardware PWM unit:
    #: those are read from their OCRnx registers)
    soft_high: dict[str, int]


def _probes(robot: Robot, elf: Path) -> list[tuple[str, int, str, int]]:
    """Per motor: (unit, duty address, direction port, bit)."""
    return [(unit, symbol(elf, f"soft_duty{soft}") & 0xFFFF if unit == "software" else OCR[unit],
             m.dir_pin[1], int(m.dir_pin[2]))
            for m, unit, soft in motor_units(*_drive_motors(robot))]


def drive_tick_cycles(robot: Robot) -> int:
    drive = robot.board("drive")
    assert drive is not None
    return drive.mcu.clock_hz * CONTROL_TICK_MS // 1000


def run_drive(robot: Robot, elf: Path, steps: list[tuple[tuple[int, ...], int]]) -> DriveRun:
    """``steps``: (wanted speeds mm/s per motor, control ticks to run) each."""
    # the TWI slave's map and the core's snapshot of it are both named regs (one static in
    # each file): both are written, the snapshot is overwritten at the next tick anyway
    regs = [a & 0xFFFF for a in symbols(elf, "regs")]
    probes = _probes(robot, elf)
    tick = drive_tick_cycles(robot)
    now = BOOT_CYCLES
    L = [f"run {now}"]
    for speeds, ticks in steps:
        data = b"".join(bytes(from_s16(v)) for v in speeds)
        L += [f"poke 0 {at} " + " ".join(str(b) for b in data) for at in regs]
        now += ticks * tick
        L.append(f"run {now}")
        L += _peeks(0, probes)
    L.append("isrs 0")
    window = tick // 100 * 64 * WINDOW_PERIODS
    assert window > tick // 100 * ISR_SPANS
    L += [f"run {now + window}", "quit"]
    soft = [m.pwm_pin[1:] for m, unit, _ in motor_units(*_drive_motors(robot)) if unit == "software"]
    out = run_commands(elf, L, ",".join(soft) or "-")
    sim = parse_events(out, 0)
    isr = Counter(sim.isr_spans(0).get(TIMER2_COMPA, [])[:ISR_SPANS])
    return DriveRun(_motor_outs(out, 0, probes), isr,
                    {pin: _high(sim.pins.get(0, []), pin, now, now + window) for pin in soft})


def _drive_motors(robot: Robot) -> tuple[tuple[DcMotor, ...], McuSpec]:
    drive = robot.board("drive")
    assert drive is not None
    return drive.motors, drive.spec


def _high(edges: list[tuple[int, str, int]], pin: str, start: int, end: int) -> int:
    """Cycles ``pin`` was high between ``start`` and ``end``."""
    level, since, high = 0, start, 0
    for cycle, name, v in edges:
        if name != pin:
            continue
        if cycle <= start:
            level = v
            continue
        if cycle >= end:
            break
        if level:
            high += cycle - since
        level, since = v, cycle
    return high + (end - since if level else 0)


def _peeks(node: int, probes: list[tuple[str, int, str, int]]) -> list[str]:
    """Driver commands printing each motor's duty register, then its direction port."""
    return ([f"peek {node} {at} 1" for _, at, _, _ in probes]
            + [f"peek {node} {PORT[p]} 1" for _, _, p, _ in probes])


def _motor_outs(out: str, node: int, probes: list[tuple[str, int, str, int]]) -> list[list[MotorOut]]:
    """The :func:`_peeks` answers of ``node``, one row per group."""
    mems = [int(w.split()[4]) for w in out.splitlines() if w.startswith(f"mem {node} ")]
    n = len(probes)
    return [[MotorOut(mems[k + i], mems[k + n + i] >> bit & 1)
             for i, (_, _, _, bit) in enumerate(probes)]
            for k in range(0, len(mems) - 2 * n + 1, 2 * n)]


def python_drive(robot: Robot, steps: list[tuple[tuple[int, ...], int]]) -> list[list[MotorOut]]:
    """The Python core over the same steps: every unit's register holds the duty."""
    core = DriveCore(robot.board("drive"))
    out = []
    for speeds, ticks in steps:
        core.write(0, b"".join(bytes(from_s16(v)) for v in speeds))
        for _ in range(ticks):
            core.tick()
        out.append([MotorOut(m.duty, int(m.forward)) for m in core.motors])
    return out


# -- cycles of the central firmware's functions ---------------------------------------

_CALL_RE = re.compile(r"^\s*([0-9a-f]+):\s+((?:[0-9a-f]{2} )+)\s*r?call\s.*<(\w+)>\s*$")


def call_returns(elf: Path, names: tuple[str, ...]) -> dict[str, list[int]]:
    """Per function: the byte address after each call of it (where its RET lands)."""
    try:
        out = subprocess.run(["avr-objdump", "-d", str(elf)], capture_output=True, text=True,
                             timeout=60, check=True).stdout
    except (OSError, subprocess.SubprocessError) as exc:
        raise SimError(f"avr-objdump {elf} failed: {exc}") from None
    found: dict[str, list[int]] = {n: [] for n in names}
    for line in out.splitlines():
        m = _CALL_RE.match(line)
        if m and m.group(3) in found:
            found[m.group(3)].append(int(m.group(1), 16) + len(m.group(2).split()))
    return found


def measure_central(robot: Robot, elf: Path, line: str) -> CentralCycles:
    """Cycles of the central firmware's core_kinematics (its first run), core_rx (the
    longest: the line's CR) and core_tick (the first after the line), from the first
    instruction of each to the instruction its RET returns to (the interrupts served
    meanwhile included, as gpsim's figures): ``line`` is sent after the boot."""
    names = ("core_kinematics", "core_rx", "core_tick")
    returns = call_returns(elf, names)
    where: dict[int, tuple[str, bool]] = {}
    for fn in names:
        if not returns[fn]:
            raise SimError(f"{elf.name}: no call of {fn}")
        where[symbol(elf, fn)] = (fn, True)
        where.update({a: (fn, False) for a in returns[fn]})
    s = CentralSetup.from_robot(robot)
    body, _, _ = script_commands(s, f"rx {line}\ntick 2\n")
    head = [f"regs {s.drive_address} {s.drive_registers}"]
    head += [f"flow 0 {i} {a} {b} {s.srad_cycles}" for i, (a, b) in enumerate(s.flow_pins)]
    head += [f"watch 0 {a}" for a in sorted(where)]
    sim = parse_events(run_commands(elf, head + body + ["quit"], "-"), 0)
    spans: dict[str, list[tuple[int, int]]] = {fn: [] for fn in names}    # (start, cycles)
    open_at: dict[str, int] = {}
    for cycle, addr in sim.hits:
        fn, entry = where[addr]
        if entry:
            open_at[fn] = cycle
        elif fn in open_at:
            begin = open_at.pop(fn)
            spans[fn].append((begin, cycle - begin))
    kin, rx = spans["core_kinematics"], spans["core_rx"]
    ticks = [d for begin, d in spans["core_tick"] if kin and begin > kin[0][0]]
    if not kin or not rx or not ticks:
        raise SimError(f"simavr: spans timed {({k: len(v) for k, v in spans.items()})}")
    return CentralCycles(kin[0][1], max(d for _, d in rx), ticks[0])
