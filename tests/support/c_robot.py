"""The host-built C firmware of the central board behind a pty (for end-to-end tests).

The host port (docs/firmware.md) reads a stimulus script and prints a trace; read from a
pipe it runs as long as the pipe stays open, one script line at a time. CFirmwareRobot
starts ``firmware_host /dev/stdin`` (stdout line-buffered by ``stdbuf -oL``), boots it,
and shuttles bytes: what a client writes on the pty becomes ``rx`` lines, the wall clock
becomes ``tick`` lines (one per Timer2 period), and the trace's ``TX`` lines go back to
the pty. The trace is kept (``lines``). No UART line time is modelled: bytes arrive at
once; held writes still wait for the tick.
"""

from __future__ import annotations

import os
import select
import subprocess
import threading
import time
import tty
from pathlib import Path


def escape(data: bytes) -> str:
    out = []
    for b in data:
        if b == 0x5C:
            out.append("\\\\")
        elif b == 0x0D:
            out.append("\\r")
        elif b == 0x0A:
            out.append("\\n")
        elif 0x20 <= b <= 0x7E:
            out.append(chr(b))
        else:
            out.append(f"\\x{b:02X}")
    return "".join(out)


class CFirmwareRobot:
    def __init__(self, binary: Path, tick_s: float):
        self.binary = Path(binary)
        self.tick_s = tick_s
        self.lines: list[str] = []
        self._stop = threading.Event()
        self.proc: subprocess.Popen[str] | None = None

    def start(self) -> str:
        master, slave = os.openpty()
        tty.setraw(slave)
        self._master, self._slave = master, slave
        self.port = os.ttyname(slave)
        self.proc = subprocess.Popen(
            ["stdbuf", "-oL", str(self.binary), "/dev/stdin"], stdin=subprocess.PIPE,
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, bufsize=1,
            cwd=self.binary.parent)
        self._send("boot")
        self._reader = threading.Thread(target=self._read_trace, daemon=True)
        self._pump = threading.Thread(target=self._pump_loop, daemon=True)
        self._reader.start()
        self._pump.start()
        return self.port

    def _send(self, line: str) -> None:
        assert self.proc is not None and self.proc.stdin is not None
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()

    def _read_trace(self) -> None:
        assert self.proc is not None and self.proc.stdout is not None
        for line in self.proc.stdout:
            line = line.rstrip("\n")
            self.lines.append(line)
            if line.startswith("TX "):
                data = bytes.fromhex(line[3:])
                try:
                    os.write(self._master, data)
                except OSError:
                    pass

    def _pump_loop(self) -> None:
        next_tick = time.monotonic() + self.tick_s
        while not self._stop.is_set():
            wait = max(0.0, next_tick - time.monotonic())
            ready, _, _ = select.select([self._master], [], [], wait)
            try:
                if ready:
                    data = os.read(self._master, 256)
                    for i in range(0, len(data), 32):
                        self._send("rx " + escape(data[i:i + 32]))
                now = time.monotonic()
                if now >= next_tick:
                    n = int((now - next_tick) / self.tick_s) + 1
                    self._send("tick" if n == 1 else f"tick {n}")
                    next_tick += n * self.tick_s
            except (OSError, ValueError):
                return

    def stop(self) -> list[str]:
        """End the firmware; its whole trace."""
        self._stop.set()
        if self.proc is not None:
            self._pump.join(timeout=5)
            try:
                self.proc.stdin.close()           # EOF: the host port's main returns
            except OSError:
                pass
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(timeout=10)
            self._reader.join(timeout=5)
            self.proc.stdout.close()
            self.proc.stderr.close()
            self.proc = None
            os.close(self._master)
            os.close(self._slave)
        return self.lines

    def __enter__(self) -> "CFirmwareRobot":
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()
