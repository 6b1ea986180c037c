"""The stimulus-script interpreter (docs/trace-format.md) over the Python core.

``python -m esair_min.harness ROBOT SCRIPT`` prints the trace on standard output; the
host-built C firmware reads the same scripts and must print the same trace.
"""

from __future__ import annotations

import sys
from collections import deque
from pathlib import Path
from typing import Callable, TextIO

from esair_min.core.i2c_bus import Bus
from esair_min.codegen.buildid import central_build_id
from esair_min.core.central import CentralCore
from esair_min.core.devices import Eeprom24, RegisterSlave, SimpleBus
from esair_min.errors import EsairError, Mark, ProtocolError
from esair_min.core.image import build_image, read_hex
from esair_min.core.script import (BLANK, LineError, decimal, hexadecimal, line_text,
                                   script_lines, unescape, words)
from esair_min.core.trace import TraceWriter, TracingBus
from esair_min.model.robot import Robot

__all__ = ["Rig", "run_line", "run_script", "main", "unescape"]

RX_BUFFER = 64   # bytes of the board's receive ring (as the PIC port's)
GAP = 0x100      # ring mark: bytes were lost just before this one
BUS_LINES = ("bus", "sda")   # `fault bus`: SCL held low; `fault sda`: SDA held low


class HeldBus:
    """A bus whose SCL or SDA line can be held low (``fault bus`` / ``fault sda``): while
    a line is held nothing reaches any device, so every transfer fails (the trace shows
    it as not acknowledged; on the PIC each one ends in the I2C master's timeout)."""

    def __init__(self, bus: Bus):
        self.bus = bus
        self.held: set[str] = set()        # "bus" (SCL) and/or "sda"

    def write(self, addr: int, data: bytes) -> bool:
        return not self.held and self.bus.write(addr, data)

    def write_read(self, addr: int, wdata: bytes, n: int) -> bytes | None:
        return None if self.held else self.bus.write_read(addr, wdata, n)


def _build_id(robot: Robot) -> str | None:
    """The build id of the robot's firmware; None for a model the generator cannot
    render (a test's variant outside the validator's rules: it has no firmware)."""
    try:
        return central_build_id(robot)
    except (EsairError, ValueError, OverflowError):
        return None


class Rig:
    """A central core wired to simple devices, a trace writer and a receive ring.

    The ring marks a loss where it happened: a byte that finds the ring full is
    dropped, and the next byte that gets in carries the mark :data:`GAP` (bytes were
    lost just before it). Feeding such a byte first tells the core (``rx_overrun``),
    so the lines that ended before the loss run and the damaged one is answered E12."""

    def __init__(self, robot: Robot, stream: TextIO | None = None):
        self.robot = robot
        self.writer = TraceWriter(stream)
        eep = robot.eeprom
        act, sen = robot.peer("actuator"), robot.peer("sensor")
        self.eeprom = (Eeprom24(eep.size_bytes, eep.address, eep.address_bytes,
                                build_image(robot), eep.page_bytes) if eep else None)
        self.actuator = RegisterSlave(act.address, act.registers) if act else None
        self.sensor = RegisterSlave(sen.address, sen.registers) if sen else None
        devices = [d for d in (self.eeprom, self.actuator, self.sensor) if d is not None]
        self.lines = HeldBus(SimpleBus(devices))
        self.bus = TracingBus(self.lines, self.writer)
        self.core = CentralCore(robot, self.bus, self.writer.tx, build_id=_build_id(robot))
        self.ring: deque[int] = deque()    # bytes, GAP set on the first after a loss
        self.lost = False                  # bytes were lost since the last one got in
        self.received = 0                  # bytes offered to the ring since the start
        self.dropped: list[int] = []       # which of them (0-based) were lost

    def boot(self) -> None:
        """Reset: the receive ring is emptied, then the core boots."""
        self.ring.clear()
        self.lost = False
        self.core.boot()

    def feed(self) -> None:
        """Bytes from the ring to the decoder while it is ready."""
        core, ring = self.core, self.ring
        while ring and core.ready():
            b = ring.popleft()
            if b & GAP:
                core.rx_overrun()
            core.rx_byte(b & 0xFF)

    def rx(self, data: bytes) -> None:
        """Each byte into the ring (dropped if it is full: the next one that gets in
        carries the mark), then feed."""
        for b in data:
            if len(self.ring) >= RX_BUFFER:
                self.lost = True
                self.dropped.append(self.received)
            else:
                self.ring.append(b | GAP if self.lost else b)
                self.lost = False
            self.received += 1
            self.feed()

    def tick(self, n: int = 1) -> None:
        for _ in range(n):
            self.writer.tick(self.core.ticks + 1)
            self.core.tick()
            self.feed()

    def device(self, name: str) -> Eeprom24 | RegisterSlave:
        dev = {"actuator": self.actuator, "sensor": self.sensor, "eeprom": self.eeprom}.get(name)
        if dev is None:
            raise ProtocolError(f"no device '{name}' (actuator, sensor or eeprom)")
        return dev


TICKS_MAX = 1_000_000      # `tick N`: at most this many ticks in one line
READING_MAX = 1023         # a sensor reading is a 10-bit value
COMMANDS = ("boot, rx TEXT, tick [N], sensor V..., fault DEVICE on|off, poke OFFSET BYTE, "
            "image PATH")


def run_line(rig: Rig, text: str, base: str = "") -> None:
    """One script line's text (line end removed, checked by ``line_text``); ``base``:
    the script's folder with its trailing ``/`` (or ""), for ``image``."""
    body = text.lstrip(BLANK)
    if not body or body.startswith("#"):
        return
    if body == "rx" or body.startswith("rx "):
        rig.rx(unescape(body[3:], len(text) - len(body) + 4))
        return
    command = body.split("#", 1)[0].rstrip(BLANK)
    cmd, *args = words(command)
    verb = _VERBS.get(cmd)
    if verb is None or not verb(rig, args, base):
        raise LineError(f"bad script line '{command}' ({COMMANDS})")


# One function a verb (``rx`` apart: its text keeps its spaces); each returns False when
# the words do not fit it (the line is then a bad script line).

def _boot(rig: Rig, args: list[str], base: str) -> bool:
    if args:
        return False
    rig.boot()
    return True


def _tick(rig: Rig, args: list[str], base: str) -> bool:
    if len(args) > 1:
        return False
    rig.tick(decimal(args[0], "tick count", TICKS_MAX) if args else 1)
    return True


def _sensor(rig: Rig, args: list[str], base: str) -> bool:
    if not args:
        return False
    dev = rig.device("sensor")
    assert isinstance(dev, RegisterSlave)
    if 2 * len(args) > len(dev.registers):
        raise LineError(f"{len(args)} readings for {len(dev.registers) // 2} sensors")
    dev.set_readings([decimal(a, "reading", READING_MAX) for a in args])
    return True


def _fault(rig: Rig, args: list[str], base: str) -> bool:
    """``fault bus|sda on|off`` holds a bus line; ``fault DEVICE on|off`` silences one."""
    if len(args) != 2 or args[1] not in ("on", "off"):
        return False
    if args[0] in BUS_LINES:
        if args[1] == "on":
            rig.lines.held.add(args[0])
        else:
            rig.lines.held.discard(args[0])
    else:
        rig.device(args[0]).fault = args[1] == "on"
    return True


def _poke(rig: Rig, args: list[str], base: str) -> bool:
    if len(args) != 2:
        return False
    dev = rig.device("eeprom")
    assert isinstance(dev, Eeprom24)
    dev.poke(hexadecimal(args[0], "poke offset", dev.size - 1),
             hexadecimal(args[1], "poke byte", 0xFF))
    return True


def _image(rig: Rig, args: list[str], base: str) -> bool:
    if len(args) != 1:
        return False
    dev = rig.device("eeprom")
    assert isinstance(dev, Eeprom24)
    dev.load(read_hex(args[0] if args[0].startswith("/") else base + args[0], dev.size))
    return True


_VERBS: dict[str, Callable[[Rig, list[str], str], bool]] = {
    "boot": _boot, "tick": _tick, "sensor": _sensor, "fault": _fault, "poke": _poke,
    "image": _image}


def run_script(robot: Robot, script: str | bytes, path: str = "<script>",
               stream: TextIO | None = None) -> list[str]:
    """Run a stimulus script (text, or the bytes of a file) line by line; the trace
    lines. An error names the script's path, line and column; the trace of the lines
    before it is written to ``stream`` already, as the host C port does."""
    data = script.encode("utf-8") if isinstance(script, str) else script
    rig = Rig(robot, stream)
    base = path[:path.rfind("/") + 1]
    for number, raw in script_lines(data):
        try:
            run_line(rig, line_text(raw), base)
        except LineError as exc:
            raise ProtocolError(exc.message, Mark(path, number, exc.column)) from None
        except EsairError as exc:
            raise ProtocolError(exc.message, Mark(path, number, 1)) from None
    rig.writer.close()
    return rig.writer.lines


def main(argv: list[str] | None = None) -> int:
    from esair_min.resources import resolve_robot
    from esair_min.model.validate import load_robot

    args = sys.argv[1:] if argv is None else argv
    if len(args) != 2:
        print("usage: python -m esair_min.harness ROBOT SCRIPT", file=sys.stderr)
        return 2
    try:
        robot = load_robot(resolve_robot(args[0]))
        try:
            data = Path(args[1]).read_bytes()
        except OSError as exc:
            raise ProtocolError(f"cannot read {args[1]}: {exc.strerror}") from None
        run_script(robot, data, args[1], sys.stdout)
    except EsairError as exc:
        sys.stdout.flush()
        print(f"error: {exc}", file=sys.stderr)
        return 1
    return 0

