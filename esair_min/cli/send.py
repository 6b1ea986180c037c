"""``esair send``: send command lines to a robot and collect one reply per line.

Works with anything pySerial opens: a serial device (``/dev/ttyUSB0``), the pty of
``esair emulate --pty``, or an ``esair://`` URL (an in-process emulator).
"""

from __future__ import annotations

import re
import time
from dataclasses import dataclass
from typing import Any, Callable, Sequence

from esair_min.errors import EsairError
from esair_min.core.protocol import add_checksum
from esair_min.serialport import describe
from esair_min.serialport import open_port as serial_port


@dataclass(frozen=True)
class Exchange:
    command: str
    reply: str
    notices: tuple[str, ...]

    @property
    def failed(self) -> bool:
        return not self.reply.startswith("OK")


#: a port another program holds is tried again this long (esair_min/serialport.py)
LOCK_WAIT_S = 3.0


def open_port(port: str, baud: int, timeout: float) -> Any:
    """A pySerial port for a device path or a URL (``esair://`` included)."""
    import serial

    try:
        return serial_port(port, lock_wait=LOCK_WAIT_S, baudrate=baud, timeout=min(timeout, 0.1))
    except (serial.SerialException, ValueError, OSError) as exc:
        raise EsairError(f"cannot open {port}: {describe(exc)}") from None


_REPLY = re.compile(r"OK\b|E\d\d\b")


def check_command(command: str) -> None:
    """Refuse a command line that would get no reply or not be one line."""
    if not command:
        raise EsairError(f"command {command!r} is empty: the robot ignores empty lines and "
                         "sends no reply; give one command per argument")
    if "\r" in command or "\n" in command:
        raise EsairError(f"command {command!r} holds a line end; give each line as its "
                         "own argument")
    try:
        command.encode("ascii")
    except UnicodeEncodeError:
        raise EsairError(f"command {command!r} is not ASCII") from None


def exchange(ser: Any, command: str, timeout: float, checksum: bool = False) -> Exchange:
    """Send one line; read lines until one that is not a ``!`` notice, or time out."""
    check_command(command)
    line = command.encode("ascii")
    if checksum:
        line = add_checksum(command).encode("ascii")
    ser.write(line + b"\r\n")
    notices: list[str] = []
    buf = bytearray()
    deadline = time.monotonic() + timeout
    while True:
        got = ser.readline()
        buf += got
        if buf.endswith(b"\n"):
            text = buf.decode("latin-1").rstrip("\r\n")
            buf.clear()
            if not text:
                continue
            # every reply is OK... or Enn ...: anything else is a notice, or the tail of
            # a line cut when the port was opened (kept with the notices, never a reply)
            if text.startswith("!") or not _REPLY.match(text):
                notices.append(text)
                continue
            return Exchange(command, text, tuple(notices))
        if time.monotonic() >= deadline:
            raise EsairError(f"no reply to {command!r} within {timeout:g} s")


def send_commands(ser: Any, commands: Sequence[str], timeout: float,
                  echo: Callable[[str], None], notices: bool = False,
                  checksum: bool = False) -> int:
    """Send each command, print its notices (if asked) and reply; return the errors.

    Every command is checked before the first is sent: a bad one sends nothing."""
    for cmd in commands:
        check_command(cmd)
    failures = 0
    for cmd in commands:
        ex = exchange(ser, cmd, timeout, checksum)
        if notices:
            for n in ex.notices:
                echo(n)
        echo(ex.reply)
        failures += ex.failed
    return failures
