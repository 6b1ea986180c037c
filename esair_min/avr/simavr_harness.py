"""Run the central board's ATmega328P firmware in simavr against a stimulus script.

The same stimulus scripts as ``python -m esair_min.harness`` and the gpsim harness
(docs/trace-format.md) become commands for the simulator driver ``simdrv.c`` (compiled
against Debian's libsimavr on first use, cached by its source's hash):

- ``rx`` bytes arrive on USART0 at line rate (10 bits per byte at the board's exact
  UBRR0 rate) from the moment the line is read, after the bytes already sent;
- the TWI bus holds the robot's motion EEPROM (the image built from the model) and the
  actuator and sensor boards as register maps (pointer byte first, wrapping), modelled
  in the driver with the master's real bit timing (16 + 2 * TWBR * 4^TWPS cycles per
  SCL period, 9 per byte);
- ``sensor`` sets the sensor board's readings, ``fault sensor on|off`` makes it stop /
  start answering, ``poke`` changes an EEPROM byte;
- ``tick N`` runs N tick periods (Timer1's exact cycle count), ``boot`` the reset,
  image check and ``!READY``, ending like the gpsim harness's (a whole number of
  reaction poll periods of ticks, early in a tick).

Cycles are CPU cycles (16 MHz on PAPA-MAN's AVR boards). The trace has the same lines
as the gpsim harness's, so :func:`esair_min.pic.gpsim_harness.compare` compares it with
the Python core's. See docs/toolchain.md, "ATmega328P".
"""

from __future__ import annotations

import hashlib
import os
import math
import re
import shutil
import subprocess
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from esair_min.core.devices import RegisterSlave
from esair_min.core.stimulus import READING_MAX
from esair_min.core.image import build_image
from esair_min.core.script import decimal, hexadecimal
from esair_min.errors import EsairError, ProtocolError
from esair_min.model import avr
from esair_min.model.robot import Robot
from esair_min.pic.gpsim_wave import I2cSegment, I2cTransfer
from esair_min.simscript import (SimScript, boot, boot_wait_end, dispatch, feed, split_replies,
                                 tick, trace_lines)

SOURCE = Path(__file__).with_name("simdrv.c")
BOOT_LEAD = 0.125


class SimError(EsairError):
    """The simulator driver could not be built or run, or the firmware crashed."""


def simulator(cache: Path | None = None, source: Path = SOURCE) -> Path:
    """A driver binary (``simdrv.c`` unless ``source`` names another), compiled
    (``gcc -Werror``) against libsimavr on first use."""
    src = source.read_bytes()
    digest = hashlib.sha256(src).hexdigest()[:16]
    base = cache or Path(tempfile.gettempdir()) / "esair-avr-driver"
    exe = base / f"{source.stem}-{digest}"
    if exe.exists():
        return exe
    if shutil.which("gcc") is None or not Path("/usr/include/simavr/sim_avr.h").exists():
        raise SimError("simavr's library is not installed (libsimavr-dev, libelf-dev); run "
                       "scripts/install-toolchain.sh (as root) to install it")
    base.mkdir(parents=True, exist_ok=True)
    tmp = exe.with_name(f"{exe.name}.{os.getpid()}.tmp")
    proc = subprocess.run(["gcc", "-O2", "-std=gnu11", "-Wall", "-Wextra", "-Werror", "-o",
                           str(tmp), str(source), "-lsimavr", "-lelf"],
                          capture_output=True, text=True, timeout=120)
    if proc.returncode != 0:
        raise SimError(f"cannot build the simavr driver:\n{proc.stderr[-2000:]}")
    tmp.replace(exe)
    return exe


@dataclass(frozen=True)
class AvrSetup:
    """The numbers the driver needs, taken from the model (names as GpsimSetup's, so the
    gpsim harness's ``compare`` takes either)."""

    clock_hz: int
    tick_cycles: int
    byte_cycles: int              # CPU cycles per UART character (10 bits)
    sync_pin: str                 # driver pin name, e.g. "D2"
    eeprom_address: int
    eeprom_size: int
    eeprom_address_bytes: int
    actuator_address: int | None
    actuator_registers: int
    sensor_address: int | None
    sensor_registers: int
    image_bytes: int
    scl_cycles: int
    poll_period: int = 1
    balances: tuple[tuple[tuple[int, ...], tuple[int, ...], int], ...] = ()

    @classmethod
    def from_robot(cls, robot: Robot) -> AvrSetup:
        c = robot.central
        tick, baud, twi = c.timer2, c.baud, c.i2c_setting
        if (c.mcu.part != "atmega328p" or robot.eeprom is None or c.sync is None
                or not isinstance(tick, avr.Timer1Tick) or not isinstance(baud, avr.UsartBaud)
                or not isinstance(twi, avr.TwiRate)):
            raise SimError("the simavr harness needs an atmega328p central board with uart, "
                           "tick, sync and an EEPROM")
        act, sen = robot.peer("actuator"), robot.peer("sensor")
        bit = (baud.ubrr + 1) * (8 if baud.u2x else 16)
        balances = tuple((tuple(i for i, x in enumerate(robot.sensors) if x.group == r.compare[0]),
                          tuple(i for i, x in enumerate(robot.sensors) if x.group == r.compare[1]),
                          r.threshold) for r in c.reactions)
        return cls(clock_hz=c.mcu.clock_hz, tick_cycles=tick.cycles, byte_cycles=10 * bit,
                   sync_pin=c.sync.pin[1:], eeprom_address=robot.eeprom.address,
                   eeprom_size=robot.eeprom.size_bytes,
                   eeprom_address_bytes=robot.eeprom.address_bytes,
                   actuator_address=act.address if act else None,
                   actuator_registers=act.registers if act else 0,
                   sensor_address=sen.address if sen else None,
                   sensor_registers=sen.registers if sen else 0,
                   image_bytes=len(build_image(robot)), scl_cycles=twi.scl_cycles,
                   poll_period=math.lcm(1, *(r.poll_ticks for r in c.reactions)),
                   balances=balances)

    @property
    def cycles_per_second(self) -> int:
        return self.clock_hz

    @property
    def boot_cycles(self) -> int:
        """A generous bound for reset, the image check and the !READY line."""
        i2c = (self.image_bytes + 16) * 9 * self.scl_cycles
        return 2 * i2c + 40 * self.byte_cycles + 100_000


@dataclass
class AvrRun:
    """What one run produced (cycles are CPU cycles)."""

    tx: list[tuple[int, int]]                          # (cycle, byte) written to UDR0
    transfers: list[I2cTransfer]
    sync_edges: list[tuple[int, int]]
    end_cycle: int
    rx: list[tuple[int, int]] = field(default_factory=list)   # (cycle, byte) read from UDR0
    lost: list[int] = field(default_factory=list)              # cycles the USART lost a byte
    min_sp: int = 0
    pins: dict[int, list[tuple[int, str, int]]] = field(default_factory=dict)  # node -> edges
    min_sps: dict[int, int] = field(default_factory=dict)
    isrs: dict[int, list[tuple[int, int]]] = field(default_factory=dict)   # (cycle, vector|0)
    hits: list[tuple[int, int]] = field(default_factory=list)   # (cycle, address) watched
    #: (node, cycle, input): a conversion of a mux's channel started before it settled
    mux_early: list[tuple[int, int, int]] = field(default_factory=list)

    def isr_spans(self, node: int = 0) -> dict[int, list[int]]:
        """Cycles from each interrupt's vectoring to its RETI, by vector number."""
        spans: dict[int, list[int]] = {}
        entry: tuple[int, int] | None = None
        for cycle, v in self.isrs.get(node, []):
            if v and entry is None:
                entry = (cycle, v)
            elif not v and entry is not None:
                spans.setdefault(entry[1], []).append(cycle - entry[0])
                entry = None
        return spans
    replies: list[tuple[int, bytes]] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.replies.extend(split_replies(self.tx))

    @property
    def stack_bytes(self) -> int:
        """The deepest the stack went (RAMEND 0x8FF)."""
        return 0x8FF - self.min_sp if self.min_sp else 0

    def trace(self) -> list[str]:
        """The run as docs/trace-format.md lines, ordered by cycle (as GpsimRun.trace)."""
        return trace_lines(self.sync_edges, self.replies, self.transfers)


class _Script(SimScript):
    """The driver commands while keeping the simulated time."""

    SECOND_BOOT = "a second boot is not supported in the AVR simulator"
    TIPPING = ("the readings set before boot tip a balance reaction: the firmware polls "
               "during the boot wait; set them after boot")

    def __init__(self, setup: AvrSetup, image: Path, boot_end: int | None,
                 channels: tuple[str, ...] | None = None):
        super().__init__(setup, boot_end)
        self.channels = channels          # the sensor board's inputs (sensor_inputs): it runs
        self.rx_free = 0
        s = setup
        self.lines = [f"eeprom {s.eeprom_address} {s.eeprom_size} {s.eeprom_address_bytes} {image}"]
        if channels is None and s.actuator_address is not None:
            self.lines.append(f"regs {s.actuator_address} {s.actuator_registers}")
        if channels is None and s.sensor_address is not None:
            self.lines.append(f"regs {s.sensor_address} {s.sensor_registers}")

    def run_lines(self, cycle: int) -> list[str]:
        return [f"run {cycle}"]

    def send(self, data: bytes) -> None:
        """Each byte's stop bit at line rate after the bytes already sent."""
        t = max(self.now, self.rx_free)
        for b in data:
            t += self.setup.byte_cycles
            self.lines.append(f"rx {t} {b}")
        self.rx_free = t


def _stimulus_line(sc: _Script, line: str) -> None:
    """One stimulus line as simavr driver commands (esair_min.simscript.dispatch,
    :data:`_VERBS`), as the gpsim harness does."""
    if dispatch(sc, line, _VERBS) is not None:
        raise ProtocolError(f"{line!r} is not supported by the AVR harness (boot, rx, tick, "
                            "sensor, fault sensor, poke)")


def _sensor(sc: _Script, args: list[str]) -> bool:
    """``sensor R...``: the readings, on the sensor board's ADC channels and mux inputs
    when it runs its firmware, else in the sensor stand-in's registers."""
    if not args:
        return False
    s = sc.setup
    readings = [decimal(a, "reading", READING_MAX) for a in args]
    if sc.channels is not None:
        if len(readings) > len(sc.channels):
            raise ProtocolError(f"{len(readings)} readings for {len(sc.channels)} sensors")
        sc.readings[:len(readings)] = readings
        sc.lines += [f"{where} {v}" for where, v in zip(sc.channels, readings, strict=False)]
        return True
    if s.sensor_address is None:
        return False
    regs = RegisterSlave(0, s.sensor_registers)
    regs.set_readings(readings)
    sc.readings[:len(readings)] = readings
    sc.lines.append(f"set {s.sensor_address} 0 " + " ".join(str(b) for b in regs.registers))
    return True


def _fault(sc: _Script, args: list[str]) -> bool:
    """``fault sensor on|off``: the sensor stand-in stops answering (not with the sensor
    board's own firmware running)."""
    if len(args) != 2 or args[0] != "sensor" or args[1] not in ("on", "off") \
            or sc.channels is not None:
        return False
    if sc.setup.sensor_address is None:
        raise ProtocolError("no sensor board")
    sc.lines.append(f"absent {sc.setup.sensor_address} {int(args[1] == 'on')}")
    return True


def _poke(sc: _Script, args: list[str]) -> bool:
    """``poke OFFSET BYTE``: a byte of the EEPROM image."""
    if len(args) != 2:
        return False
    s = sc.setup
    offset = hexadecimal(args[0], "poke offset", s.eeprom_size - 1)
    byte = hexadecimal(args[1], "poke byte", 0xFF)
    sc.lines.append(f"set {s.eeprom_address} {offset} {byte}")
    return True


_VERBS: dict[str, Callable[[_Script, list[str]], bool]] = {
    "boot": boot, "tick": tick, "sensor": _sensor, "fault": _fault, "poke": _poke}


#: The sensor board's node in run_robot.
SENSOR_NODE = 2


def sensor_inputs(robot: Robot, node: int) -> tuple[str, ...]:
    """Where each sensor's reading goes in the driver, in register order: its ADC channel
    (``adc NODE CH``) or its input of the board's mux (``muxin NODE IN``)."""
    return tuple(f"adc {node} {x.channel}" if x.mux_input is None else f"muxin {node} {x.mux_input}"
                 for x in robot.sensors)


def mux_line(robot: Robot, node: int) -> list[str]:
    """The driver's ``mux`` line for the sensor board's multiplexer (none without one):
    its channel, select pins and settling time in cycles (the board file's, rounded up)."""
    b = robot.sensor_board
    if b is None or b.mux is None:
        return []
    settle = -(-b.mux.settle_us * b.mcu.clock_hz // 1_000_000)
    return [f"mux {node} {b.mux.channel} {','.join(p[1:] for p in b.mux.select)} {settle}"]


def build_commands(robot: Robot, stimulus: str, image: Path, boot_end: int | None = None,
                   boards: bool = False) -> tuple[list[str], AvrSetup]:
    """The driver commands running ``stimulus`` (the EEPROM image file at ``image``);
    ``boards``: the actuator and sensor boards run their firmware (nodes 1 and 2)."""
    channels = sensor_inputs(robot, SENSOR_NODE) if boards else None
    sc = _Script(AvrSetup.from_robot(robot), image, boot_end, channels)
    feed(sc, stimulus, _stimulus_line)
    return sc.lines + ["quit"], sc.setup


def parse_events(out: str, scl_cycles: int) -> AvrRun:
    tx, rx, sync, lost, transfers = [], [], [], [], []
    pins: dict[int, list[tuple[int, str, int]]] = {}
    isrs: dict[int, list[tuple[int, int]]] = {}
    hits: list[tuple[int, int]] = []
    early: list[tuple[int, int, int]] = []
    sps: dict[int, int] = {}
    cur: I2cTransfer | None = None
    end = 0
    for line in out.splitlines():
        w = line.split()
        if not w:
            continue
        kind = w[0]
        if kind == "crash":
            raise SimError(f"the firmware of node {w[1]} stopped the simulator at cycle {w[2]} "
                           f"(state {w[3]})")
        if kind == "tx":
            tx.append((int(w[1]), int(w[2])))
        elif kind == "rd":
            rx.append((int(w[1]), int(w[2])))
        elif kind == "pin":
            node, cycle, name, level = int(w[1]), int(w[2]), w[3], int(w[4])
            if node == 0:
                sync.append((cycle, level))
            pins.setdefault(node, []).append((cycle, name, level))
        elif kind == "lost":
            lost.append(int(w[1]))
        elif kind == "pc":
            hits.append((int(w[2]), int(w[3])))
        elif kind == "mux":
            early.append((int(w[1]), int(w[2]), int(w[4])))
        elif kind == "isr":
            isrs.setdefault(int(w[1]), []).append((int(w[2]), int(w[3])))
        elif kind == "sp":
            sps[int(w[1])] = int(w[3])
        elif kind == "at":
            end = int(w[1])
        elif kind == "i2c":
            cycle = int(w[1])
            if w[2] == "start":
                cur = I2cTransfer(start=cycle)
                transfers.append(cur)
                cur.segments.append(I2cSegment(-1, False))
            elif cur is None:
                continue
            elif w[2] == "restart":
                cur.segments.append(I2cSegment(-1, False))
            elif w[2] == "stop":
                cur.stop = cycle
            elif w[2] == "byte":
                b, ack = int(w[3]), w[4] == "1"
                seg = cur.segments[-1]
                if seg.addr_byte < 0:
                    seg.addr_byte, seg.addr_ack = b, ack
                else:
                    seg.data.append((b, ack))
                cur.last_byte_end = cycle
    if transfers and transfers[-1].stop is None:
        transfers.pop()               # cut by the end of the run
    return AvrRun(tx=tx, transfers=transfers, sync_edges=sync, end_cycle=end, rx=rx,
                  lost=lost, min_sp=sps.get(0, 0), pins=pins, min_sps=sps, isrs=isrs, hits=hits,
                  mux_early=early)


def run_commands(elf: Path, commands: list[str], pins: str, timeout: float = 300.0,
                 nodes: tuple[str, ...] = ()) -> str:
    """Run the driver: node 0 is ``elf`` watching ``pins``; ``nodes``: more ``node``
    (and ``wire``) lines for the peers."""
    exe = simulator()
    head = [f"node {elf} {pins or '-'}", *nodes]
    try:
        proc = subprocess.run([str(exe)], input="\n".join(head + commands) + "\n",
                              capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        raise SimError(f"the AVR simulator took more than {timeout:g} s") from None
    if proc.returncode not in (0, 3):
        raise SimError(f"the AVR simulator failed ({proc.returncode}): {proc.stderr[-2000:]}")
    return proc.stdout


def boot_end(robot: Robot, elf: Path, workdir: Path, lead: float = BOOT_LEAD) -> int:
    """The cycle the ``boot`` wait ends at (see esair_min.pic.gpsim_harness.boot_end):
    whole reaction poll periods of ticks served, ``lead`` of a tick after a tick."""
    s = AvrSetup.from_robot(robot)
    if s.poll_period == 1:
        return s.boot_cycles
    image = _image(robot, workdir)
    cmds, _ = build_commands(robot, "boot\n", image)
    run = parse_events(run_commands(elf, cmds, s.sync_pin), s.scl_cycles)
    rises = [c for c, v in run.sync_edges if v == 1 and c > 0]
    if not rises or rises[0] > s.boot_cycles:
        raise SimError("no tick (sync rising edge) during the boot wait")
    return boot_wait_end(rises, s.boot_cycles, s.tick_cycles, s.poll_period, lead)


def _image(robot: Robot, workdir: Path) -> Path:
    workdir.mkdir(parents=True, exist_ok=True)
    path = workdir / "image.bin"
    path.write_bytes(build_image(robot))
    return path


def compare(python_trace: list[str], avr_trace: list[str], setup: AvrSetup,
            held: bool = False) -> list[str]:
    """The gpsim harness's comparison (esair_min.pic.gpsim_harness.compare), with one
    normalisation: a refused transfer is compared by its address alone. The Python core
    lists a read the sensor board refused as ``R aa <pointer> <n> NACK``; on the wire
    the register-pointer write was refused at the address (``W aa NACK``): the master
    never got to the read."""
    from esair_min.pic.gpsim_harness import compare as compare_traces
    refused = re.compile(r"^[RW] ([0-9A-F]{2}) .*NACK$")

    def norm(lines: list[str]) -> list[str]:
        return [refused.sub(r"W \1  NACK", line) for line in lines]
    return compare_traces(norm(python_trace), norm(avr_trace), setup, held)  # type: ignore[arg-type]


def run_stimulus(robot: Robot, stimulus: str, elf: Path, workdir: Path,
                 lead: float = BOOT_LEAD, isrs: bool = False,
                 watch: tuple[int, ...] = ()) -> AvrRun:
    """Run ``stimulus`` on the central firmware ``elf`` (firmware.elf); ``isrs``: record
    every interrupt's entry and RETI (AvrRun.isr_spans); ``watch``: byte addresses
    whose every execution is recorded (AvrRun.hits)."""
    end = boot_end(robot, elf, workdir, lead)
    cmds, setup = build_commands(robot, stimulus, _image(robot, workdir), end)
    if isrs:
        cmds.insert(0, "isrs 0")
    cmds[:0] = [f"watch 0 {a}" for a in watch]
    return parse_events(run_commands(elf, cmds, setup.sync_pin), setup.scl_cycles)


def servo_pins(robot: Robot) -> str:
    """The actuator's servo pins as the driver names them (``PD3`` -> ``D3``), by index."""
    return ",".join(x.pin[1:] for x in robot.servos)


def run_robot(robot: Robot, stimulus: str, elfs: dict[str, Path], workdir: Path,
              lead: float = BOOT_LEAD, timeout: float = 600.0,
              watch: tuple[int, tuple[int, ...]] | None = None) -> AvrRun:
    """Run ``stimulus`` on all three boards' firmware in lockstep: the central board
    (node 0) with the motion EEPROM modelled, the actuator (node 1: its sync input
    wired to the central's sync output, its servo pins recorded) and the sensor board
    (node 2: ``sensor`` lines set its ADC inputs) as TWI slaves on the same bus.
    ``watch``: (node, byte addresses) whose every execution is recorded (AvrRun.hits)."""
    act, sen = robot.actuator, robot.sensor_board
    if act is None or sen is None or act.sync is None or robot.central.sync is None:
        raise SimError("run_robot needs a central, an actuator and a sensor board")
    end = boot_end(robot, elfs["central"], workdir / "boot", lead)
    setup = AvrSetup.from_robot(robot)
    cmds, _ = build_commands(robot, stimulus, _image(robot, workdir), end, boards=True)
    watched = [] if watch is None else [f"watch {watch[0]} {a}" for a in watch[1]]
    nodes = (f"node {elfs['actuator']} {servo_pins(robot)}", f"node {elfs['sensor']} -",
             *mux_line(robot, SENSOR_NODE),
             f"wire 0 {robot.central.sync.pin[1:]} 1 {act.sync.pin[1:]}", *watched)
    out = run_commands(elfs["central"], cmds, setup.sync_pin, timeout, nodes)
    return parse_events(out, setup.scl_cycles)


@dataclass(frozen=True)
class Pulse:
    servo: int
    rise: int            # cycle
    width_us: float


def pulses(run: AvrRun, robot: Robot, clock_hz: int, node: int = 1) -> list[Pulse]:
    """Every complete pulse on the actuator's servo pins (rise to fall)."""
    index = {x.pin[1:]: x.index for x in robot.servos}
    up: dict[str, int] = {}
    out = []
    for cycle, name, level in run.pins.get(node, []):
        if level:
            up.setdefault(name, cycle)
        elif name in up:
            rise = up.pop(name)
            out.append(Pulse(index[name], rise, (cycle - rise) * 1e6 / clock_hz))
    return out


def symbols(elf: Path, name: str) -> list[int]:
    """The addresses of every symbol ``name`` in ``elf`` (avr-nm; statics of several files
    may share a name; data: 0x800000 + the data-space address)."""
    out = subprocess.run(["avr-nm", str(elf)], capture_output=True, text=True, timeout=30).stdout
    found = [int(w[0], 16) for w in (line.split() for line in out.splitlines())
             if len(w) == 3 and w[2] == name]
    if not found:
        raise SimError(f"no symbol {name} in {elf}")
    return found


def symbol(elf: Path, name: str) -> int:
    """The byte address of function ``name`` in ``elf`` (avr-nm)."""
    return symbols(elf, name)[0]
