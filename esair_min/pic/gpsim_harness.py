"""Run the central board's PIC18F452 firmware in gpsim against a stimulus script.

The same stimulus scripts as ``python -m esair_min.harness`` (docs/trace-format.md)
become a gpsim command file generated from the model:

- gpsim's ``usart`` module on RC6/RC7 at the board's baud sends the ``rx`` bytes at line
  rate (its transmit FIFO queues them) and ``log w _TXREG`` records every reply byte;
- an ``e24xx256`` at the EEPROM's address (A0..A2 tied by pull-ups) holds the robot's
  motion image, loaded with ``load e`` from an Intel HEX file;
- an ``i2c2par`` module at the actuator board's address stands in for the actuator (it
  ACKs every byte written); the sensor board's stand-in is an ``e24xx024`` (256 bytes,
  1-byte memory address: a register map) when its address is a free 0x50..0x57, with
  the readings in its memory, else another ``i2c2par`` (every byte read returns its 8
  pins, set by pull-ups/pull-downs, so all readings are equal);
- ``FileRecorder`` modules record SCL, SDA and the sync pin; the bus is decoded from
  the waveforms (:mod:`esair_min.pic.gpsim_wave`), like a logic analyser would;
- ``fault bus on`` / ``fault sda on`` set the SCL / SDA pull-up to 0 V: the line is held
  low (a stuck bus, a slave holding SCL) until ``off`` puts it back at 5 V. The log also
  records every write to SSPCON1 (the firmware's MSSP resets on an I2C timeout), every
  read of RCREG (when each received byte was taken) and every write to PIE1 (TXIE is
  set as each reply byte enters the transmit ring).

``tick N`` runs N tick periods of simulated time (Timer2's exact instruction count);
``boot`` runs until the start-up image check and the ``!READY`` line are done, then
on to a whole number of reaction poll periods of ticks (see :func:`boot_ticks`).
Everything is deterministic. See docs/toolchain.md, section "gpsim harness".
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from esair_min.errors import ProtocolError
from esair_min.pic.gpsim_wave import I2cTransfer, decode_i2c, read_edges, read_register_log
from esair_min.core.devices import RegisterSlave
from esair_min.core.stimulus import READING_MAX
from esair_min.core.script import decimal, hexadecimal
from esair_min.core.image import build_image, write_hex
from esair_min.model.avr import Timer1Tick
from esair_min.model.robot import Robot
from esair_min.pic.toolchain import Toolchain, ToolchainError, run_gpsim
from esair_min.simscript import (SimScript, boot, boot_wait_end, dispatch, feed, split_replies,
                                 tick, trace_lines)

BOOT_LEAD = 0.125          # of a tick: where the boot wait (and so every tick N) ends
HOLD_PULLUPS = {"bus": "PSCL", "sda": "PSDA"}   # `fault bus|sda on`: this pull-up at 0 V
SSPEN = 0x20               # SSPCON1: the MSSP on
TXIE = 0x10                # PIE1: the transmit interrupt on
E24XX256_BYTES = 32768     # the motion EEPROM stand-in's size
UNUSED_ADDRESS = 0x7F      # an i2c2par moved here stops answering (fault on)
NO_WRITE_NACK = ("gpsim 0.31's MSSP master keeps driving SDA with the last bit of a byte "
                 "during the ACK clock, so a missing device is seen as ACKing every byte "
                 "that ends in 0 (every write address): only read NACKs can be simulated")


@dataclass(frozen=True)
class GpsimSetup:
    """The numbers a gpsim command file needs, taken from the model."""

    clock_hz: int
    baud: int
    tick_cycles: int          # instruction cycles per Timer2 tick
    sync_pin: str             # gpsim pin name, e.g. "portb0"
    eeprom_address: int       # 7-bit, 0x50..0x57 (the e24xx256 answers only there)
    actuator_address: int | None
    sensor_address: int | None
    image_bytes: int
    sensor_registers: int = 0
    poll_period: int = 1      # ticks: the least common multiple of the reactions' polls
    balances: tuple[tuple[tuple[int, ...], tuple[int, ...], int], ...] = ()  # a, b, threshold

    @classmethod
    def from_robot(cls, robot: Robot) -> GpsimSetup:
        central = robot.central
        timer2 = central.timer2
        assert not isinstance(timer2, Timer1Tick), "the gpsim harness runs PIC18F452 boards"
        if (central.uart is None or central.sync is None or timer2 is None
                or robot.eeprom is None):
            raise ToolchainError("the gpsim harness needs a central board with uart, tick, "
                                 "sync and an EEPROM")
        eep = robot.eeprom.address
        if eep & 0x78 != 0x50:
            raise ToolchainError(f"EEPROM address 0x{eep:02X}: gpsim's e24xx256 answers "
                                 "only at 0x50..0x57")
        act, sen = robot.peer("actuator"), robot.peer("sensor")
        period = math.lcm(1, *(r.poll_ticks for r in central.reactions))
        balances = tuple((tuple(i for i, x in enumerate(robot.sensors) if x.group == r.compare[0]),
                          tuple(i for i, x in enumerate(robot.sensors) if x.group == r.compare[1]),
                          r.threshold) for r in central.reactions)
        return cls(clock_hz=central.mcu.clock_hz, baud=central.uart.baud,
                   tick_cycles=timer2.instructions,
                   sync_pin=_gpsim_pin(central.sync.pin), eeprom_address=eep,
                   actuator_address=act.address if act else None,
                   sensor_address=sen.address if sen else None,
                   image_bytes=len(build_image(robot)),
                   sensor_registers=sen.registers if sen else 0, poll_period=period,
                   balances=balances)

    @property
    def sensor_is_memory(self) -> bool:
        """The sensor stand-in is an ``e24xx024`` (a free address in 0x50..0x57)."""
        a = self.sensor_address
        return a is not None and a & 0x78 == 0x50 and a != self.eeprom_address

    @property
    def sensor_fault_pin(self) -> int:
        """The address pin of the ``e24xx024`` flipped by ``fault sensor on``: the
        first that moves it to an address nobody else answers at."""
        taken = {self.eeprom_address, self.actuator_address, self.sensor_address}
        assert self.sensor_address is not None
        return next(b for b in range(3) if self.sensor_address ^ (1 << b) not in taken)

    @property
    def cycles_per_second(self) -> int:
        return self.clock_hz // 4

    @property
    def byte_cycles(self) -> int:
        """Instruction cycles per UART character (10 bits), rounded up."""
        return -(-10 * self.cycles_per_second // self.baud)

    @property
    def boot_cycles(self) -> int:
        """A generous bound for reset, image check at 100 kHz and the !READY line."""
        i2c = (self.image_bytes + 16) * 9 * (self.cycles_per_second // 100_000)
        return 2 * i2c + 40 * self.byte_cycles + 100_000


def _gpsim_pin(pin: str) -> str:
    m = re.fullmatch(r"R([A-E])([0-7])", pin)
    if not m:
        raise ToolchainError(f"pin {pin!r} is not a port pin")
    return f"port{m.group(1).lower()}{m.group(2)}"


@dataclass
class GpsimRun:
    """What one gpsim run of a stimulus script produced (cycles are instruction cycles)."""

    output: str                                        # gpsim's console output
    tx: list[tuple[int, int]]                          # (cycle, byte) written to TXREG
    transfers: list[I2cTransfer]                       # decoded from SCL/SDA
    sync_edges: list[tuple[int, int]]                  # (cycle, level) of the sync pin
    end_cycle: int
    replies: list[tuple[int, bytes]] = field(default_factory=list)   # (cycle of LF, line)
    rx: list[tuple[int, int]] = field(default_factory=list)          # (cycle, byte) read from RCREG
    bus_resets: list[int] = field(default_factory=list)   # cycles the firmware reset the MSSP
    holds: tuple[tuple[int, int], ...] = ()                # cycles a line was held low
    queued: list[int] = field(default_factory=list)  # cycle each TX byte entered the ring

    def reply_times(self) -> list[tuple[int, bytes]]:
        """(cycle its first byte entered the transmit ring, line) of every reply."""
        out, at = [], 0
        for _, line in self.replies:
            out.append((self.queued[at], line))
            at += len(line)
        return out

    def __post_init__(self) -> None:
        self.replies.extend(split_replies(self.tx))

    def trace(self) -> list[str]:
        """The run as docs/trace-format.md lines (``T`` = rising sync edges counted
        from reset, ``@`` marks in microseconds), ordered by cycle."""
        return trace_lines(self.sync_edges, self.replies, self.transfers)


class _Script(SimScript):
    """Builds the gpsim command file while keeping the simulated time."""

    SECOND_BOOT = "a second boot is not supported in gpsim"
    TIPPING = ("the readings set before boot tip a balance reaction: gpsim's firmware polls "
               "during the boot wait (its ticks run from reset), the Python core does not; "
               "set them after boot")

    def __init__(self, setup: GpsimSetup, boot_end: int | None = None):
        super().__init__(setup, boot_end)
        self.held: dict[str, int] = {}          # line -> cycle its hold began
        self.holds: list[tuple[int, int]] = []  # (first, last) cycle of each hold

    def set_readings(self, values: list[int]) -> None:
        self.readings[:len(values)] = values

    def hold(self, line: str, on: bool) -> None:
        """Hold SCL (``bus``) or SDA (``sda``) low from now on, or release it."""
        if on and line not in self.held:
            self.held[line] = self.now
        elif not on and line in self.held:
            # the pull-up's edge comes one cycle after the break the script stopped at
            self.holds.append((self.held.pop(line), self.now + 1))
        self.lines.append(f"{HOLD_PULLUPS[line]}.voltage = {0.0 if on else 5.0}")

    def run_lines(self, cycle: int) -> list[str]:
        return [f"break c {cycle}", "run"]

    def send(self, data: bytes) -> None:
        self.lines += [f"U1.tx = {b:#04x}" for b in data]


def _pin_levels(value: int) -> list[int]:
    """The byte an i2c2par sensor stand-in must return so every reading is ``value``."""
    b = value & 0xFF
    if value != b | (b << 8):
        raise ProtocolError(f"gpsim's sensor stand-in returns the same byte for every "
                            f"register: reading {value} is not b + 256*b (use 0, 257, 514 "
                            "or 771)")
    return [(b >> i) & 1 for i in range(8)]


def build_script(robot: Robot, stimulus: str, cod_name: str, image_name: str,
                 after_boot: tuple[str, ...] = (),
                 epilogue: tuple[str, ...] = (),
                 boot_end: int | None = None) -> tuple[str, GpsimSetup]:
    """The gpsim command file running ``stimulus`` on firmware ``cod_name``.

    ``after_boot``: commands inserted right after the ``boot`` wait (the benchmarks set
    their breakpoints there); ``epilogue``: commands run after the last stimulus line;
    ``boot_end``: the cycle the ``boot`` wait ends at (:func:`boot_end`; default
    ``GpsimSetup.boot_cycles``)."""
    sc = _build(robot, stimulus, cod_name, image_name, after_boot, epilogue, boot_end)
    return "\n".join(sc.lines) + "\n", sc.setup


def _build(robot: Robot, stimulus: str, cod_name: str, image_name: str,
           after_boot: tuple[str, ...], epilogue: tuple[str, ...],
           boot_end: int | None, prologue: tuple[str, ...] = ()) -> _Script:
    s = GpsimSetup.from_robot(robot)
    sc = _Script(s, boot_end)
    sc.lines += setup_lines(s, cod_name, image_name)
    sc.lines += prologue
    feed(sc, stimulus, _stimulus_line, after_boot)
    sc.lines += epilogue
    sc.lines += ["log off", 'FSCL.file = "/dev/null"', 'FSDA.file = "/dev/null"',
                 'FSYNC.file = "/dev/null"', "cycles", "quit"]
    sc.holds += [(start, sc.now + 1) for start in sc.held.values()]   # held to the end
    return sc


def setup_lines(s: GpsimSetup, cod_name: str, image_name: str) -> list[str]:
    """Processor, modules, nodes and recorders (see the module docstring)."""
    L = [f"load {cod_name}", "p18f452.BreakOnInvalidRegisterWrite = false",
         f"frequency {s.clock_hz}", "module library libgpsim_modules.so.0",
         # the PC end of the serial link
         "module load usart U1", f"U1.txbaud = {s.baud}", f"U1.rxbaud = {s.baud}",
         "node ntx", "node nrx", "attach ntx portc6 U1.RXPIN", "attach nrx portc7 U1.TXPIN",
         # the I2C bus: pull-ups, recorders, the motion EEPROM
         "module load pullup PSCL", "module load pullup PSDA",
         "module load FileRecorder FSCL", "module load FileRecorder FSDA",
         "module load FileRecorder FSYNC",
         "FSCL.digital = true", "FSDA.digital = true", "FSYNC.digital = true",
         'FSCL.file = "scl.txt"', 'FSDA.file = "sda.txt"', 'FSYNC.file = "sync.txt"',
         "module load e24xx256 EE"]
    scl = ["nscl", "portc3", "PSCL.pin", "FSCL.pin", "EE.SCL"]
    sda = ["nsda", "portc4", "PSDA.pin", "FSDA.pin", "EE.SDA"]
    # chip-select pins: the e24xx256 answers at 0x50 | A2A1A0
    for bit in range(3):
        if s.eeprom_address >> bit & 1:
            L += [f"module load pullup PA{bit}", f"node na{bit}",
                  f"attach na{bit} EE.A{bit} PA{bit}.pin"]
    for name, addr in (("ACT", s.actuator_address), ("SEN", s.sensor_address)):
        if addr is None:
            continue
        if name == "SEN" and s.sensor_is_memory:
            # a register map: its A0..A2 each on a pull-up at 5 V or 0 V (a fault moves one)
            L.append("module load e24xx024 SEN")
            for bit in range(3):
                L += [f"module load pullup PSA{bit}", f"node nsa{bit}",
                      f"attach nsa{bit} SEN.A{bit} PSA{bit}.pin"]
            L += _address_levels(addr)
            L += [f"SEN.eeData[{i:#x}] = 0x00" for i in range(s.sensor_registers)]
        else:
            L += [f"module load i2c2par {name}", f"{name}.Slave_Address = {addr:#04x}"]
        scl.append(f"{name}.SCL")
        sda.append(f"{name}.SDA")
    if s.sensor_address is not None and not s.sensor_is_memory:
        # each port pin of the sensor stand-in on its own node, pulled to 0 or 5 V
        for i in range(8):
            L += [f"module load pullup PS{i}", f"node nsp{i}", f"attach nsp{i} SEN.p{i} PS{i}.pin"]
        L += _sensor_levels(_pin_levels(0))
    L += [f"node {scl[0]}", f"node {sda[0]}", "attach " + " ".join(scl),
          "attach " + " ".join(sda), "node nsync", f"attach nsync {s.sync_pin} FSYNC.pin",
          f"load e EE {image_name}", "log on regs.log", "log w _TXREG",
          "log w _SSPCON1", "log r _RCREG", "log w _PIE1"]
    return L


def _address_levels(address: int) -> list[str]:
    """The e24xx024 stand-in's address pins for ``address`` (0x50..0x57)."""
    return [f"PSA{b}.voltage = {5.0 if address >> b & 1 else 0.0}" for b in range(3)]


def _sensor_bytes(s: GpsimSetup, values: list[int]) -> list[str]:
    """The e24xx024 stand-in's memory for these readings: 10-bit (low, high) pairs in
    register order, as the Python core's sensor board (same checks, same errors)."""
    regs = RegisterSlave(0, s.sensor_registers)
    regs.set_readings(values)
    return [f"SEN.eeData[{i:#x}] = {b:#04x}" for i, b in enumerate(regs.registers)]


def _sensor_levels(levels: list[int]) -> list[str]:
    return [f"PS{i}.voltage = {5.0 if v else 0.0}" for i, v in enumerate(levels)]


def _stimulus_line(sc: _Script, line: str) -> None:
    """One stimulus line as gpsim commands (esair_min.simscript.dispatch, :data:`_VERBS`)."""
    cmd = dispatch(sc, line, _VERBS)
    if cmd is None:
        return
    if cmd == "fault":
        raise ProtocolError(f"{line!r}: only 'fault sensor', 'fault bus' and 'fault sda' "
                            "work in gpsim; " + NO_WRITE_NACK)
    raise ProtocolError(f"{line!r} is not supported by the gpsim harness (boot, rx, "
                        "tick, sensor, fault sensor|bus|sda, poke)")


def _sensor(sc: _Script, args: list[str]) -> bool:
    """``sensor R...``: the sensor stand-in's readings (a register map's bytes, or the
    port pins of an i2c2par stand-in, which answers one byte for every register)."""
    if not args:
        return False
    readings = [decimal(a, "reading", READING_MAX) for a in args]
    if sc.setup.sensor_is_memory:
        sc.lines += _sensor_bytes(sc.setup, readings)
        sc.set_readings(readings)
        return True
    values = set(readings)
    if len(values) != 1:
        raise ProtocolError("gpsim's sensor stand-in returns one byte for every "
                            "register: all readings must be equal")
    sc.set_readings(readings)
    sc.lines += _sensor_levels(_pin_levels(values.pop()))
    return True


def _fault(sc: _Script, args: list[str]) -> bool:
    """``fault sensor on|off`` (the sensor board stops answering) and ``fault bus|sda
    on|off`` (a bus line held low)."""
    if len(args) != 2 or args[1] not in ("on", "off"):
        return False
    s, on = sc.setup, args[1] == "on"
    if args[0] == "sensor":
        if s.sensor_address is None:
            raise ProtocolError("no sensor board")
        if s.sensor_is_memory:
            moved = s.sensor_address ^ (1 << s.sensor_fault_pin) if on else s.sensor_address
            sc.lines += _address_levels(moved)
        else:
            sc.lines.append(f"SEN.Slave_Address = "
                            f"{UNUSED_ADDRESS if on else s.sensor_address:#04x}")
        return True
    if args[0] in HOLD_PULLUPS:
        sc.hold(args[0], on)
        return True
    return False


def _poke(sc: _Script, args: list[str]) -> bool:
    """``poke OFFSET BYTE``: a byte of the motion EEPROM."""
    if len(args) != 2:
        return False
    offset = hexadecimal(args[0], "poke offset", E24XX256_BYTES - 1)
    sc.lines.append(f"EE.eeData[{offset:#x}] = {hexadecimal(args[1], 'poke byte', 0xFF):#04x}")
    return True


#: The stimulus verbs gpsim runs (``rx`` apart: its text keeps its spaces).
_VERBS: dict[str, Callable[[_Script, list[str]], bool]] = {
    "boot": boot, "tick": tick, "sensor": _sensor, "fault": _fault, "poke": _poke}


def boot_end(robot: Robot, cod: Path, workdir: Path, tc: Toolchain | None = None,
             lead: float = BOOT_LEAD) -> int:
    """The cycle the ``boot`` wait ends at, so the reactions poll on the same ticks as in
    the Python core, and a script line after a ``tick`` comes early in a tick period.

    The firmware's Timer2 runs from reset, every tick is queued and served after
    ``core_boot`` (where the poll countdowns start), while the Python core counts ticks
    from the end of ``boot``: the wait must hold a whole number of poll periods. A
    short gpsim run of the boot alone finds the ticks: the sync pin rises at a tick
    only if the previous one was served (it stays high during the image check), so
    tick 1 is the first rising edge and Timer2 is exactly periodic. The wait then ends
    ``lead`` of a tick (default ``BOOT_LEAD``) after a tick, so every ``tick N`` ends
    there too and bytes received next are decoded before the next tick if they fit in
    the rest of it.
    Without reactions: ``GpsimSetup.boot_cycles`` (no run)."""
    s = GpsimSetup.from_robot(robot)
    if s.poll_period == 1:
        return s.boot_cycles
    script, _ = build_script(robot, "boot\n", str(Path(cod).resolve()), "image.hex")
    workdir.mkdir(parents=True, exist_ok=True)
    write_hex(build_image(robot), workdir / "image.hex")
    run_gpsim(script, workdir, tc=tc, script_name="boot.stc")
    rises = [c for c, v in read_edges(workdir / "sync.txt") if v == 1 and c > 0]
    if not rises or rises[0] > s.boot_cycles:
        raise ToolchainError("no tick (sync rising edge) during the boot wait")
    return boot_wait_end(rises, s.boot_cycles, s.tick_cycles, s.poll_period, lead)


def run_stimulus(robot: Robot, stimulus: str, cod: Path, workdir: Path,
                 tc: Toolchain | None = None, timeout: float = 120.0,
                 lead: float = BOOT_LEAD, prologue: tuple[str, ...] = (),
                 epilogue: tuple[str, ...] = ()) -> GpsimRun:
    """Run ``stimulus`` on the central firmware ``cod`` (a .cod file) in ``workdir``;
    ``lead``: see :func:`boot_end`; ``prologue``: gpsim commands before the firmware
    runs, ``epilogue``: after the last stimulus line (their output is in ``output``)."""
    workdir.mkdir(parents=True, exist_ok=True)
    cod_rel = Path(cod).resolve()
    end = boot_end(robot, cod_rel, workdir / "boot", tc, lead)
    write_hex(build_image(robot), workdir / "image.hex")
    sc = _build(robot, stimulus, str(cod_rel), "image.hex", (), epilogue, end, prologue)
    script = "\n".join(sc.lines) + "\n"
    out = run_gpsim(script, workdir, timeout=timeout, tc=tc, script_name="harness.stc")
    if "***ERROR" in out:
        raise ToolchainError("gpsim rejected a command:\n" + "\n".join(
            line for line in out.splitlines() if "ERROR" in line or "while parsing" in line))
    ends = re.findall(r"(\d+) = 0x[0-9A-Fa-f]+\s*$", out, re.M)
    log = workdir / "regs.log"
    tx = [(c, v) for c, _, v in read_register_log(log, {"_TXREG"})]
    holds = tuple(sc.holds)
    transfers = decode_i2c(read_edges(workdir / "scl.txt"), read_edges(workdir / "sda.txt"),
                           holds)
    if transfers and transfers[-1].stop is None and not transfers[-1].cut:
        transfers.pop()          # cut by the end of the run
    return GpsimRun(output=out, tx=tx, transfers=transfers,
                    sync_edges=read_edges(workdir / "sync.txt"),
                    end_cycle=int(ends[-1]) if ends else 0,
                    rx=[(c, v) for c, _, v in read_register_log(log, {"_RCREG"}, reads=True)],
                    bus_resets=[c for c, _, v in read_register_log(log, {"_SSPCON1"})
                                if not v & SSPEN],
                    holds=holds,
                    queued=[c for c, _, v in read_register_log(log, {"_PIE1"}) if v & TXIE])


def _normalise(line: str) -> str:
    """A trace line as compared: a refused transfer is its address and NACK only (the
    PIC stops sending at the NACK; the Python trace lists what it wanted to send)."""
    words = line.split()
    if words[-1] == "NACK":
        return f"{words[0]} {words[1]} NACK"
    return line


def projections(lines: list[str], eeprom: int, actuator: int | None,
                sensor: int | None) -> dict[str, list[str]]:
    """The parts of a trace that must be equal however bytes and ticks interleave:
    the UART lines, the actuator writes, the EEPROM reads and page writes, the sensor
    reads. Probes (``P`` lines; an address alone on the wire) are left out: the EEPROM
    acknowledges its polls after its own write cycle, which the Python core does not
    time; their outcome is in the replies (``OK``, ``E10``, i2c_scan's list)."""
    out: dict[str, list[str]] = {"uart": [], "actuator": [], "eeprom": [], "sensor": []}
    by_addr = {eeprom: "eeprom", actuator: "actuator", sensor: "sensor"}
    for line in lines:
        if line.startswith("P "):
            continue
        if line.startswith("TX "):
            out["uart"].append(line)
        elif line[:2] in ("W ", "R "):
            words = line.split()
            addr = int(words[1], 16)
            if words[0] == "W" and len(words) == 3 and (words[2] == "ACK" or addr == eeprom
                                                        or addr not in by_addr):
                continue      # an address alone (a probe): polls and i2c_scan, compared
            if addr == eeprom and words[0] == "W" and words[-1] == "NACK":
                continue      # ... by the replies (a refused write is a NACKed probe)
            key = by_addr.get(addr)
            if key is None:
                raise ToolchainError(f"I2C transfer to an unknown address: {line}")
            out[key].append(_normalise(line))
    return out


def compare(python_trace: list[str], gpsim_trace: list[str], setup: GpsimSetup,
            held: bool = False) -> list[str]:
    """Differences between the two traces, one message per part; [] when they agree.

    UART lines, actuator writes and EEPROM reads must be equal in order. Sensor reads
    must be equal in content; gpsim may have a few more: the firmware's Timer2 runs
    from reset, so ticks pass during the image check and the ``boot`` wait (the
    Python core counts ticks from the end of ``boot``), and polls fall on every
    ``poll_ticks``-th tick.

    ``held``: the script held a bus line (``fault bus|sda``). Failed transfers (NACK
    lines) are then left out on both sides: while a line is held the PIC's START is
    refused (nothing on the wire) or its transfer is cut, while the Python core lists
    every transfer it tried as not acknowledged. The replies say which failed."""
    a = projections(python_trace, setup.eeprom_address, setup.actuator_address,
                    setup.sensor_address)
    b = projections(gpsim_trace, setup.eeprom_address, setup.actuator_address,
                    setup.sensor_address)
    if held:
        for part in (a, b):
            for key in ("actuator", "eeprom", "sensor"):
                part[key] = [line for line in part[key] if not line.endswith(" NACK")]
    diffs = []
    for key in ("uart", "actuator", "eeprom"):
        if a[key] != b[key]:
            first = next((i for i, (x, y) in enumerate(zip(a[key], b[key])) if x != y),
                         min(len(a[key]), len(b[key])))
            diffs.append(f"{key}: {len(a[key])} lines in Python, {len(b[key])} in gpsim; "
                         f"first difference at {first}: "
                         f"{a[key][first] if first < len(a[key]) else '-'} / "
                         f"{b[key][first] if first < len(b[key]) else '-'}")
    extra = setup.boot_cycles // setup.tick_cycles + 2
    if set(a["sensor"]) != set(b["sensor"]) or not (
            len(a["sensor"]) - 2 <= len(b["sensor"]) <= len(a["sensor"]) + extra):
        diffs.append(f"sensor: Python {len(a['sensor'])} reads {sorted(set(a['sensor']))}, "
                     f"gpsim {len(b['sensor'])} reads {sorted(set(b['sensor']))}")
    return diffs
