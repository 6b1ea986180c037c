"""STARFISH's central board: its PIC18F452 firmware in gpsim against the Python core,
on the same byte stream at the same times.

Stimulus (one command a line, ``#`` comments):

- ``rx TEXT``: the line TEXT and CR LF are sent at 9600 baud (gpsim's ``usart`` module;
  lines queue behind each other at line rate); ``raw HH ...``: these bytes;
- ``tick N``: N tick periods of simulated time pass (Timer2's exact instruction count);
- ``floor S 0|1``: flow sensor S's SDIO line is pulled low / high from now on, so every
  register read of it gives 0x00 / 0xFF (no ADNS-2610 model runs in gpsim: the pull
  stands in for it; the firmware never waits on the sensor).

gpsim runs the firmware with an ``i2c2par`` at the drive board's address (it ACKs every
byte), ``FileRecorder`` modules on SCL/SDA and on every flow sensor's SCLK and SDIO, and
a log of TXREG writes (replies), RCREG reads (when each byte was taken) and the T2CON
write (when Timer2 started: tick k is Timer2's k-th period after it). The Python core
(:class:`~esair_min.components.omni_base.core.StarfishCore`) is then fed the same
events in the same order: each received byte at the cycle the firmware took it, each
tick at its period's end; a line end closer than :data:`MARGIN` of a tick to a tick
boundary is refused (which comes first would be a matter of a few cycles, not of the
logic). Compared (:func:`compare`): the reply lines, the I2C writes (decoded from the
waveforms like a logic analyser would) and every flow sensor's register reads
(address byte and the data byte on the wire, decoded from SCLK/SDIO).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from esair_min.components.omni_base.sim_replay import FlowChange, Run, replay, reply_lines
from esair_min.components.omni_base.sim_replay import compare as compare_runs
from esair_min.core.script import unescape
from esair_min.errors import ProtocolError
from esair_min.model.hardware import Timer2Setting
from esair_min.model.robot import Robot
from esair_min.pic.gpsim_harness import _gpsim_pin
from esair_min.pic.gpsim_wave import decode_i2c, read_edges, read_register_log
from esair_min.pic.toolchain import Toolchain, ToolchainError, run_gpsim

BOOT_CYCLES = 40_000      # reset (SDCC's start-up, ~15 000 cycles), hal_init, core_init
SERVED = 15_000           # cycles: a tick this long before the end has been served
DRAIN_TICKS = 10          # after the last line: the replies leave the transmit ring (96 bytes)
MARGIN = 500              # cycles: a line end this close to a tick is refused (ambiguous)
T2CON_ADDR = 0xFCA


@dataclass(frozen=True)
class Setup:
    clock_hz: int
    baud: int
    tick_cycles: int
    drive_address: int
    flow_pins: tuple[tuple[str, str], ...]     # (SCLK, SDIO) gpsim pin names per sensor

    @classmethod
    def from_robot(cls, robot: Robot) -> Setup:
        c, drive = robot.central, robot.board("drive")
        if (c.uart is None or c.timer2 is None or drive is None or drive.i2c is None
                or drive.i2c.address is None):
            raise ToolchainError("STARFISH's gpsim harness needs uart:, tick: and a drive board")
        assert isinstance(c.timer2, Timer2Setting), "a PIC18F452 central board"
        return cls(c.mcu.clock_hz, c.uart.baud, c.timer2.instructions, drive.i2c.address,
                   tuple((_gpsim_pin(f.sclk_pin), _gpsim_pin(f.sdio_pin))
                         for f in c.flow_sensors))


@dataclass
class _Script:
    """The gpsim command file being built from a stimulus, and where it stands."""

    setup: Setup
    lines: list[str]
    now: int                                               # cycle of the last break
    floors: list[tuple[int, int, int]] = field(default_factory=list)   # (cycle, sensor, level)


def _rx(sc: _Script, data: bytes) -> None:
    """``rx TEXT`` (CR LF added) and ``raw HH ...``: the bytes go out on the line."""
    sc.lines += [f"U1.tx = {b:#04x}" for b in data]


def _raw(sc: _Script, args: list[str]) -> bool:
    if not args:
        return False
    _rx(sc, bytes(int(a, 16) for a in args))
    return True


def _tick(sc: _Script, args: list[str]) -> bool:
    if len(args) != 1 or int(args[0]) <= 0:
        return False
    sc.now += int(args[0]) * sc.setup.tick_cycles
    sc.lines += [f"break c {sc.now}", "run"]
    return True


def _floor(sc: _Script, args: list[str]) -> bool:
    if len(args) != 2 or args[1] not in ("0", "1"):
        return False
    sensor, pins = int(args[0]), sc.setup.flow_pins
    if sensor >= len(pins):
        raise ProtocolError(f"floor {sensor}: there are {len(pins)} flow sensors")
    sc.floors.append((sc.now, sensor, int(args[1])))
    sc.lines.append(f"PF{sensor}.voltage = {5.0 if args[1] == '1' else 0.0}")
    return True


#: The stimulus verbs (``rx`` apart: its text keeps its spaces); each returns False when
#: the words do not fit it (a number that is not one raises ValueError: the same).
_VERBS: dict[str, Callable[[_Script, list[str]], bool]] = {
    "raw": _raw, "tick": _tick, "floor": _floor}


def _stimulus_line(sc: _Script, number: int, text: str) -> None:
    """One stimulus line as gpsim commands, by the function of its verb."""
    if text.startswith("rx ") or text == "rx":
        _rx(sc, unescape(text[3:]) + b"\r\n")
        return
    words = text.split("#", 1)[0].split()
    if not words:
        return
    verb = _VERBS.get(words[0])
    try:
        if verb is not None and verb(sc, words[1:]):
            return
    except ValueError:
        pass
    raise ProtocolError(f"stimulus line {number}: {text!r} is not rx TEXT, raw HH ..., "
                        "tick N or floor S 0|1")


def gpsim_script(s: Setup, stimulus: str, cod: str) -> tuple[str, list[tuple[int, int, int]]]:
    """The command file, and the floor changes ``(cycle, sensor, level)``."""
    sc = _script(s, stimulus, cod)
    return "\n".join(sc.lines) + "\n", sc.floors


def _script(s: Setup, stimulus: str, cod: str) -> _Script:
    """The command file's lines built from ``stimulus``; ``now`` is its end cycle."""
    L = [f"load {cod}", "p18f452.BreakOnInvalidRegisterWrite = false",
         f"frequency {s.clock_hz}", "module library libgpsim_modules.so.0",
         "module load usart U1", f"U1.txbaud = {s.baud}", f"U1.rxbaud = {s.baud}",
         "node ntx", "node nrx", "attach ntx portc6 U1.RXPIN", "attach nrx portc7 U1.TXPIN",
         "module load pullup PSCL", "module load pullup PSDA",
         "module load FileRecorder FSCL", "module load FileRecorder FSDA",
         "FSCL.digital = true", "FSDA.digital = true",
         'FSCL.file = "scl.txt"', 'FSDA.file = "sda.txt"',
         "module load i2c2par DRV", f"DRV.Slave_Address = {s.drive_address:#04x}",
         "node nscl", "node nsda", "attach nscl portc3 PSCL.pin FSCL.pin DRV.SCL",
         "attach nsda portc4 PSDA.pin FSDA.pin DRV.SDA"]
    for i, (sclk, sdio) in enumerate(s.flow_pins):
        L += [f"module load pullup PF{i}", f"PF{i}.voltage = 0.0",
              f"module load FileRecorder FC{i}", f"module load FileRecorder FD{i}",
              f"FC{i}.digital = true", f"FD{i}.digital = true",
              f'FC{i}.file = "sclk{i}.txt"', f'FD{i}.file = "sdio{i}.txt"',
              f"node nfc{i}", f"node nfd{i}", f"attach nfc{i} {sclk} FC{i}.pin",
              f"attach nfd{i} {sdio} PF{i}.pin FD{i}.pin"]
    L += ["log on regs.log", "log w _TXREG", "log r _RCREG", "log w _T2CON"]
    L += [f"break c {BOOT_CYCLES}", "run"]
    sc = _Script(s, L, BOOT_CYCLES)
    for number, text in enumerate(stimulus.splitlines(), start=1):
        _stimulus_line(sc, number, text)
    sc.now += DRAIN_TICKS * s.tick_cycles
    L += [f"break c {sc.now}", "run", "log off", 'FSCL.file = "/dev/null"',
          'FSDA.file = "/dev/null"']
    L += [f'FC{i}.file = "/dev/null"\nFD{i}.file = "/dev/null"' for i in range(len(s.flow_pins))]
    L += ["cycles", "quit"]
    return sc


def decode_flow(sclk: list[tuple[int, int]], sdio: list[tuple[int, int]]) -> list[str]:
    """``"RR DD"`` per register read: SDIO sampled at each rising SCLK edge, 16 bits a
    read (the address byte the PIC sends, the data byte it reads)."""
    bits = []
    at, level = 0, 0
    for c, v in sclk:
        if v != 1 or c == 0:
            continue
        while at < len(sdio) and sdio[at][0] < c:
            level = sdio[at][1]
            at += 1
        bits.append(level)
    out = []
    for k in range(0, len(bits) - 15, 16):
        b = bits[k:k + 16]
        addr = int("".join(map(str, b[:8])), 2)
        data = int("".join(map(str, b[8:])), 2)
        out.append(f"{addr:02X} {data:02X}")
    return out


def run_gpsim_side(robot: Robot, stimulus: str, cod: Path, workdir: Path,
                   tc: Toolchain | None = None) -> tuple[Run, list[tuple[int, int]], int, int,
                                                         list[tuple[int, int, int]]]:
    """gpsim's Run, the bytes taken ``(cycle, byte)``, Timer2's start cycle, the end
    cycle and the floor changes."""
    s = Setup.from_robot(robot)
    sc = _script(s, stimulus, str(Path(cod).resolve()))
    out = run_gpsim("\n".join(sc.lines) + "\n", workdir, timeout=300, tc=tc, script_name="starfish.stc")
    if "***ERROR" in out:
        raise ToolchainError("gpsim rejected a command:\n" + out[-2000:])
    log = workdir / "regs.log"
    tx = [v for _, _, v in read_register_log(log, {"_TXREG"})]
    rx = [(c, v) for c, _, v in read_register_log(log, {"_RCREG"}, reads=True)]
    t2 = [c for c, _, _ in read_register_log(log, {"_T2CON"})]
    if not t2:
        raise ToolchainError("gpsim: the firmware never started Timer2")
    run = Run()
    run.replies = reply_lines(bytes(tx))
    transfers = decode_i2c(read_edges(workdir / "scl.txt"), read_edges(workdir / "sda.txt"))
    run.writes = [t.trace_line() for t in transfers if t.segments and t.stop is not None]
    run.flow = [decode_flow(read_edges(workdir / f"sclk{i}.txt"),
                            read_edges(workdir / f"sdio{i}.txt"))
                for i in range(len(s.flow_pins))]
    return run, rx, t2[0], sc.now, sc.floors


def python_side(robot: Robot, rx: list[tuple[int, int]], t2_start: int, end: int,
                floors: list[tuple[int, int, int]]) -> Run:
    """The Python core fed the gpsim run's events in their order (see the module doc)."""
    s = Setup.from_robot(robot)
    # the last tick must have been served before the run ended
    ticks = [t2_start + k * s.tick_cycles
             for k in range(1, (end - t2_start) // s.tick_cycles + 1)
             if t2_start + k * s.tick_cycles <= end - SERVED]
    changes = [FlowChange(c, sensor, floor=level) for c, sensor, level in floors]
    return replay(robot, rx, ticks, changes, MARGIN)


def compare(python: Run, gpsim: Run) -> list[str]:
    """Differences, one message per part; [] when the runs agree."""
    return compare_runs(python, gpsim, "gpsim")


def differential(robot: Robot, stimulus: str, cod: Path, workdir: Path,
                 tc: Toolchain | None = None) -> tuple[Run, Run]:
    """(Python, gpsim) runs of ``stimulus``."""
    g, rx, t2, end, floors = run_gpsim_side(robot, stimulus, cod, workdir, tc)
    return python_side(robot, rx, t2, end, floors), g


@dataclass(frozen=True)
class CentralCycles:
    kinematics: int           # core_kinematics of the velocity line
    rx_line: int              # core_rx of its CR (parse, limits, kinematics, I2C write, reply)
    tick: int                 # core_tick (two sensors' three registers, sums, watchdog)


def measure_central(robot: Robot, cod: Path, lst: Path, workdir: Path, line: str,
                    tc: Toolchain | None = None) -> CentralCycles:
    """Cycles of the central firmware's functions in gpsim (execution breakpoints on
    each function's entry and returns, ``cycles`` at each hit): ``line`` is sent after
    the boot; the first core_kinematics, the longest core_rx (the line's CR) and the
    first core_tick after the line are reported."""
    from esair_min.pic.gpsim_bench import RETURN_CYCLES, function_spans, parse_hits

    s = Setup.from_robot(robot)
    spans = function_spans(lst.read_text(errors="replace"))
    names: dict[int, tuple[str, bool]] = {}
    for fn in ("_core_kinematics", "_core_rx", "_core_tick"):
        if fn not in spans or not spans[fn].exits:
            raise ToolchainError(f"{lst.name}: no function {fn} with a return")
        names[spans[fn].entry] = (fn, True)
        names.update({a: (fn, False) for a in spans[fn].exits})
    script, _ = gpsim_script(s, "", str(Path(cod).resolve()))
    head = script.split("\nlog on regs.log")[0].splitlines()
    data = line.encode("ascii") + b"\r\n"
    L = head + [f"break c {BOOT_CYCLES}", "run"] + [f"U1.tx = {b:#04x}" for b in data]
    L += [f"break e {a:#x}" for a in sorted(names)]
    L += [f"break c {BOOT_CYCLES + (len(data) + 2) * 6000 + 2 * s.tick_cycles}"]
    L += ["run", "cycles"] * (2 * (len(data) + 8)) + ["quit"]
    out = run_gpsim("\n".join(L) + "\n", workdir, timeout=300, tc=tc, script_name="bench.stc")
    got: dict[str, list[int]] = {"_core_kinematics": [], "_core_rx": [], "_core_tick": []}
    open_at: dict[str, int] = {}
    for h in parse_hits(out):
        if h.addr not in names:
            continue
        fn, entry = names[h.addr]
        if entry:
            open_at.setdefault(fn, h.cycle)
        elif fn in open_at:
            got[fn].append(h.cycle + RETURN_CYCLES - open_at.pop(fn))
    if not got["_core_kinematics"] or len(got["_core_rx"]) < len(data) - 1 or not got["_core_tick"]:
        raise ToolchainError(f"gpsim: spans timed {({k: len(v) for k, v in got.items()})}")
    return CentralCycles(got["_core_kinematics"][0], max(got["_core_rx"]), got["_core_tick"][0])
