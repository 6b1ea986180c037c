"""STARFISH's central board in Python: the command decoder of docs/protocol.md
(STARFISH), the kinematics and limits, the command watchdog, the flow-sensor polling
and the odometry sums. What the generated C will do, line for line and byte for byte
on the bus; the emulator and the tests drive it.

Replies and error codes are PAPA-MAN's (:mod:`esair_min.core.protocol`); the watchdog's
notice is ``!W watchdog stop``.
"""

from __future__ import annotations

import functools
import re
import struct
from collections.abc import Callable, Sequence
from typing import Any, Protocol

from esair_min.components.omni_base.kinematics import wheel_speeds, wheel_table
from esair_min.components.optical_flow.core import read_deltas
from esair_min.core.decoder import LineAssembler
from esair_min.core.protocol import CHECKSUM_CHARS, ERROR_LINE, OK_LINE, PROTOCOL_NAME, Code
from esair_min.core.protocol import velocity_line  # noqa: F401  (the omni base's V line)

WATCHDOG_NOTICE = b"!W watchdog stop\r\n"
#: The command set: prefix -> (action, characters of a matching line).
COMMANDS: dict[bytes, tuple[str, int]] = {
    b"V": ("velocity", 16), b"W": ("wheels", 16), b"O": ("odometry", 1),
    b"x": ("stop", 1), b"v": ("version", 1),
}
_HEX = b"0123456789ABCDEF"
U32 = 1 << 32
#: Three signed fields (signed_field's ``+0123`` / ``-0123``) after the command letter.
_FIELDS = re.compile(rb"([+-][0-9]{4})([+-][0-9]{4})([+-][0-9]{4})").fullmatch
_M32 = U32 - 1
#: How many V/W lines' plans a core keeps (:meth:`StarfishCore.line`): all are dropped
#: when one more comes.
PLANS = 64


class FlowReader(Protocol):
    def address(self, reg: int, t_ns: int) -> None: ...
    def data(self, t_ns: int) -> int: ...


def signed_field(a: bytes) -> int | None:
    """``+0123`` / ``-0123`` -> the number, else None (E03)."""
    if len(a) != 5 or a[0] not in b"+-" or not a[1:].isdigit():
        return None
    v = int(a[1:])
    return -v if a[0] == 0x2D else v


def watchdog_ticks(watchdog_ms: int, tick_ns: int) -> int:
    """Whole ticks of ``tick_ns`` covering ``watchdog_ms`` (rounded up)."""
    return -(-watchdog_ms * 1_000_000 // tick_ns)


def version_line(robot: str, wheels: int, flow: int, watchdog_ms: int, checksum: bool,
                 robot_id: str | None = None) -> bytes:
    """The ``v`` reply; ``robot_id``: an emulator's boot (docs/protocol.md, "Robot id")."""
    ident = f" id={robot_id}" if robot_id is not None else ""
    return (f"OK {PROTOCOL_NAME} {robot} wheels={wheels} flow={flow} watchdog={watchdog_ms} "
            f"checksum={'on' if checksum else 'off'}{ident}").encode() + b"\r\n"


def ready_line(robot: str) -> bytes:
    """The notice the emulated central board sends at reset: the robot it is, by name
    (``!READY esair-min/1 starfish-avr`` for STARFISH on the AVR), as its ``v`` reply."""
    return f"!READY {PROTOCOL_NAME} {robot}\r\n".encode()


def wheels_line(speeds: Sequence[int]) -> str:
    return "W" + "".join(f"{v:+05d}" for v in speeds)


class StarfishCore:
    """The central board of an omni-base robot."""

    def __init__(self, robot: Any, write: Callable[[int, bytes], bool],
                 flow: Sequence[FlowReader] = (), robot_id: str | None = None):
        central = robot.central
        # the v reply's id=: an emulator's boot; the firmware has none
        self.robot_id = robot_id
        base = central.base
        self.name = robot.name
        drive = robot.board("drive")
        self.wheels = wheel_table(sorted(drive.motors, key=lambda m: m.index))
        self.drive_address = drive.i2c.address
        self.max_v = base.max_speed_mm_s
        self.max_w = base.max_omega_mrad_s
        t2 = central.timer2
        self.tick_ns = round(t2.period_s * 1e9)
        self.watchdog_ms = base.watchdog_ms
        self.watchdog_ticks = watchdog_ticks(base.watchdog_ms, self.tick_ns)
        self.require_checksum = bool(central.uart and central.uart.require_checksum)
        self.flow_names = [f.name for f in central.flow_sensors]
        self.flow = list(flow)
        # each sensor's tick reads: its own burst where it has one (Adns2610.deltas)
        self._readers = [getattr(f, "deltas", None)
                         or functools.partial(read_deltas, f)  # type: ignore[arg-type]
                         for f in self.flow]
        self.write_bus = write
        self._pack = struct.Struct(f"<B{len(self.wheels)}H").pack
        self.lines = LineAssembler()
        # a V/W line's body -> its refusal, or its drive write and wheel speeds: the same
        # line again (a host repeats its velocity to feed the watchdog) is not parsed,
        # turned into wheel speeds and checked against the limits again
        self._plans: dict[bytes, bytes | tuple[bytes, list[int]]] = {}
        self.commanded = [0] * len(self.wheels)
        self.idle_ticks = 0
        self.sums = [[0, 0, 0] for _ in self.flow_names]      # dx, dy (mod 2^32), squal
        self.polls = 0
        self.t_ns = 0
        self.watchdog_stops = 0

    # -- the link ------------------------------------------------------------------------
    def feed(self, data: bytes) -> bytes:
        got = self.lines.feed_run(data)
        if len(got) < 2:                         # (the usual run: one line end at most)
            if not got:
                return b""
            r = got[0]
            return ERROR_LINE[r] if isinstance(r, Code) else self.line(r)
        out = bytearray()
        for r in got:                            # a line does not change the assembly
            out += ERROR_LINE[r] if isinstance(r, Code) else self.line(r)
        return bytes(out)

    def _strip(self, line: bytes) -> bytes | Code:
        n = len(line)
        if n >= CHECKSUM_CHARS and line[n - 3] == 0x2A:
            x = 0
            for c in line[:n - 3]:
                x ^= c
            if line[n - 2] != _HEX[x >> 4] or line[n - 1] != _HEX[x & 15]:
                return Code.BAD_CHECKSUM
            return line[:n - 3]
        return Code.CHECKSUM_REQUIRED if self.require_checksum else line

    def line(self, line: bytes) -> bytes:
        """One whole line (terminator removed): the reply."""
        body = self._strip(line)
        if isinstance(body, Code):
            return ERROR_LINE[body]
        row = COMMANDS.get(body[:1])
        if row is None:
            return ERROR_LINE[Code.UNKNOWN]
        action, length = row
        if len(body) != length:
            return ERROR_LINE[Code.BAD_ARGUMENT]
        if action in ("velocity", "wheels"):
            plan = self._plans.get(body)
            if plan is None:
                plan = self._plan(action, body)
                if len(self._plans) >= PLANS:
                    self._plans.clear()
                self._plans[body] = plan
            if isinstance(plan, bytes):
                return plan
            reply = self._write_drive(*plan)
        elif action == "stop":
            reply = self._send([0] * len(self.wheels))
        elif action == "odometry":
            reply = self._odometry()
        else:
            reply = version_line(self.name, len(self.wheels), len(self.flow_names),
                                 self.watchdog_ms, self.require_checksum, self.robot_id)
        if reply.startswith(b"OK"):
            self.idle_ticks = 0                  # a command carried out feeds the watchdog
        return reply

    def _plan(self, action: str, body: bytes) -> bytes | tuple[bytes, list[int]]:
        """A V/W line's body: its refusal (E03, E04), or the drive write and the wheel
        speeds it asks for."""
        m = _FIELDS(body, 1)                     # signed_field of each, at once
        if m is None:
            return ERROR_LINE[Code.BAD_ARGUMENT]
        args = [int(a) for a in m.groups()]
        if action == "velocity":
            vx, vy, w = args
            if abs(vx) > self.max_v or abs(vy) > self.max_v or abs(w) > self.max_w:
                return ERROR_LINE[Code.OUTSIDE_LIMITS]
            speeds = wheel_speeds(self.wheels, vx, vy, w)
        else:
            speeds = args
        if any(abs(s) > wh.limit_mm_s for s, wh in zip(speeds, self.wheels, strict=True)):
            return ERROR_LINE[Code.OUTSIDE_LIMITS]
        return self._pack(0, *[v & 0xFFFF for v in speeds]), speeds   # from_s16 of each

    def _send(self, speeds: list[int]) -> bytes:
        return self._write_drive(self._pack(0, *[v & 0xFFFF for v in speeds]), speeds)

    def _write_drive(self, data: bytes, speeds: list[int]) -> bytes:
        if not self.write_bus(self.drive_address, data):
            return ERROR_LINE[Code.NO_ANSWER]
        self.commanded = list(speeds)
        return OK_LINE

    def _odometry(self) -> bytes:
        parts = [f"n={self.polls & 0xFFFF}"]
        for i, (dx, dy, q) in enumerate(self.sums):
            parts.append(f"{chr(0x61 + i)}={_s32(dx)},{_s32(dy)},{q}")
        return ("OK " + " ".join(parts)).encode() + b"\r\n"

    # -- the tick ------------------------------------------------------------------------
    def tick(self) -> bytes:
        """One tick: poll the flow sensors, run the watchdog; the notices it sends."""
        t = self.t_ns = self.t_ns + self.tick_ns
        for read, s in zip(self._readers, self.sums, strict=True):
            dx, dy, s[2], t = read(t)
            if dx:
                s[0] = (s[0] + dx) & _M32
            if dy:
                s[1] = (s[1] + dy) & _M32
        self.polls += 1
        idle = self.idle_ticks
        if idle < 0xFFFF:
            self.idle_ticks = idle = idle + 1
        if idle >= self.watchdog_ticks and any(self.commanded):
            self._send([0] * len(self.wheels))
            self.commanded = [0] * len(self.wheels)   # even if the write was not answered
            self.watchdog_stops += 1
            return WATCHDOG_NOTICE
        return b""


def _s32(v: int) -> int:
    return v - U32 if v & 0x80000000 else v
