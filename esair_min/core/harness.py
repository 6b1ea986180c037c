"""The stimulus-script interpreter (docs/trace-format.md) over the Python core.

``python -m esair_min.harness ROBOT SCRIPT`` prints the trace on standard output; the
host-built C firmware reads the same scripts and must print the same trace.
"""

from __future__ import annotations

import sys
from collections import deque
from pathlib import Path
from typing import TextIO

from esair_min.core.bus import Bus
from esair_min.core.central import CentralCore
from esair_min.core.devices import Eeprom24, RegisterSlave, SimpleBus
from esair_min.errors import EsairError, Mark, ProtocolError
from esair_min.core.image import build_image, read_hex
from esair_min.model.robot import Robot
from esair_min.core.trace import TraceWriter, TracingBus

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
                                build_image(robot)) if eep else None)
        self.actuator = RegisterSlave(act.address, act.registers) if act else None
        self.sensor = RegisterSlave(sen.address, sen.registers) if sen else None
        devices = [d for d in (self.eeprom, self.actuator, self.sensor) if d is not None]
        self.lines = HeldBus(SimpleBus(devices))
        self.bus = TracingBus(self.lines, self.writer)
        self.core = CentralCore(robot, self.bus, self.writer.tx)
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


def unescape(text: str) -> bytes:
    r"""The bytes of an ``rx`` text: C escapes ``\r`` ``\n`` ``\xHH`` ``\\``."""
    out = bytearray()
    i = 0
    while i < len(text):
        c = text[i]
        if c != "\\":
            if not 0x20 <= ord(c) <= 0x7E:
                raise ProtocolError(f"character {c!r} in rx text (write it as \\xHH)")
            out.append(ord(c))
            i += 1
            continue
        e = text[i + 1: i + 2]
        if e == "r":
            out.append(0x0D)
        elif e == "n":
            out.append(0x0A)
        elif e == "\\":
            out.append(0x5C)
        elif e == "x" and _is_hex(text[i + 2: i + 4]):
            out.append(int(text[i + 2: i + 4], 16))
            i += 2
        else:
            raise ProtocolError(f"unknown escape {text[i:i + 4]!r} (use \\r \\n \\xHH \\\\)")
        i += 2
    return bytes(out)


def _is_hex(s: str) -> bool:
    return len(s) == 2 and all(c in "0123456789abcdefABCDEF" for c in s)


def _int(word: str, base: int, what: str) -> int:
    try:
        return int(word, base)
    except ValueError:
        raise ProtocolError(f"{what} {word!r} is not a {'hex' if base == 16 else 'decimal'} "
                            f"number") from None


def run_line(rig: Rig, line: str, base: Path) -> None:
    """One script line (comments and blank lines already removed for non-rx lines)."""
    if line == "rx" or line.startswith("rx "):
        rig.rx(unescape(line[3:]))
        return
    words = line.split("#", 1)[0].split()
    if not words:
        return
    cmd, args = words[0], words[1:]
    if cmd == "boot" and not args:
        rig.boot()
    elif cmd == "tick" and len(args) <= 1:
        n = _int(args[0], 10, "tick count") if args else 1
        if n < 0:
            raise ProtocolError(f"tick count {n} is negative")
        rig.tick(n)
    elif cmd == "sensor" and args:
        dev = rig.device("sensor")
        assert isinstance(dev, RegisterSlave)
        dev.set_readings([_int(a, 10, "reading") for a in args])
    elif cmd == "fault" and len(args) == 2 and args[0] in BUS_LINES and args[1] in ("on", "off"):
        if args[1] == "on":
            rig.lines.held.add(args[0])
        else:
            rig.lines.held.discard(args[0])
    elif cmd == "fault" and len(args) == 2 and args[1] in ("on", "off"):
        rig.device(args[0]).fault = args[1] == "on"
    elif cmd == "poke" and len(args) == 2:
        dev = rig.device("eeprom")
        assert isinstance(dev, Eeprom24)
        dev.poke(_int(args[0], 16, "offset"), _int(args[1], 16, "byte"))
    elif cmd == "image" and len(args) == 1:
        dev = rig.device("eeprom")
        assert isinstance(dev, Eeprom24)
        path = Path(args[0]) if Path(args[0]).is_absolute() else base / args[0]
        dev.load(read_hex(path, dev.size))
    else:
        raise ProtocolError(f"bad script line {line!r} (boot, rx TEXT, tick [N], "
                            f"sensor V..., fault DEVICE on|off, poke OFFSET BYTE, image PATH)")


def run_script(robot: Robot, script: str, path: str = "<script>",
               stream: TextIO | None = None) -> list[str]:
    """Run a stimulus script; the trace lines. Errors name the script line."""
    rig = Rig(robot, stream)
    base = Path(path).parent
    for number, raw in enumerate(script.splitlines(), start=1):
        line = raw.rstrip("\r\n")
        stripped = line.strip()
        if not stripped or stripped.startswith("#"):
            continue
        try:
            run_line(rig, line.lstrip() if stripped.startswith("rx") else stripped, base)
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
        script = Path(args[1]).read_text(encoding="utf-8")
        run_script(robot, script, args[1], sys.stdout)
    except EsairError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    except OSError as exc:
        print(f"error: {args[1]}: {exc.strerror}", file=sys.stderr)
        return 1
    return 0

