"""The Python core of an omni base's central board run over a stimulus script, writing
the trace the generated host port writes (firmware_templates/omni_central/ports/host):
the two are compared line for line (tests/min/test_starfish_c.py).

Script: ``rx TEXT`` (the line and CR LF arrive), ``raw HH ...`` (bytes), ``tick N``,
``flow S DX DY Q`` (sensor S's next Delta_X, Delta_Y, cleared when read, and SQUAL),
``nack 0|1`` (the drive board answers or not). Trace: ``W AA DD ... ACK|NACK`` per I2C
write, ``TX text`` per line sent.
"""

from __future__ import annotations

from typing import Any

from esair_min.components.omni_base.core import StarfishCore
from esair_min.components.optical_flow.core import REG_DELTA_X, REG_DELTA_Y, REG_SQUAL


class ScriptFlow:
    """A flow sensor whose next readings the script sets."""

    def __init__(self) -> None:
        self.dx = self.dy = self.q = 0
        self._reg = 0

    def address(self, reg: int, t_ns: int) -> None:
        self._reg = reg

    def data(self, t_ns: int) -> int:
        if self._reg == REG_DELTA_X:
            v, self.dx = self.dx, 0
        elif self._reg == REG_DELTA_Y:
            v, self.dy = self.dy, 0
        elif self._reg == REG_SQUAL:
            v = self.q
        else:
            v = 0
        return v & 0xFF


def run_script(robot: Any, script: str) -> list[str]:
    """The trace of ``script`` through the Python core."""
    out: list[str] = []
    state = {"nack": False}
    drive = robot.board("drive").i2c.address

    def write(addr: int, data: bytes) -> bool:
        ok = not state["nack"] and addr == drive
        out.append(f"W {addr:02X} " + " ".join(f"{b:02X}" for b in data)
                   + (" ACK" if ok else " NACK"))
        return ok

    flows = [ScriptFlow() for _ in robot.central.flow_sensors]
    core = StarfishCore(robot, write, flows)
    pending = bytearray()

    def emit(data: bytes) -> None:
        pending.extend(data)
        while b"\r\n" in pending:
            line, _, rest = bytes(pending).partition(b"\r\n")
            out.append("TX " + line.decode("latin-1"))
            pending[:] = rest

    for text in script.splitlines():
        if text.startswith("rx ") or text == "rx":
            emit(core.feed(text[3:].encode("latin-1") + b"\r\n"))
        elif text.startswith("raw "):
            emit(core.feed(bytes(int(t, 16) for t in text[4:].split())))
        elif text.startswith("tick "):
            for _ in range(int(text[5:])):
                emit(core.tick())
        elif text.startswith("nack "):
            state["nack"] = text[5:] == "1"
        elif text.startswith("flow "):
            s, dx, dy, q = (int(t) for t in text[5:].split())
            flows[s].dx, flows[s].dy, flows[s].q = dx, dy, q
        elif text:
            raise ValueError(f"unknown script line {text!r}")
    return out
