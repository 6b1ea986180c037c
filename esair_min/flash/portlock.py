"""The port's lock, taken as every ESAIR program takes it (an exclusive advisory ``flock``
on the device, what pySerial's ``exclusive=True`` does: esair_min/serialport.py), and held
while a tool that takes no lock of its own (avrdude) uses the port. A port another program
holds is refused with who holds it (from /proc/locks)."""

from __future__ import annotations

import fcntl
import os
from pathlib import Path

from esair_min.flash import FlashError


def holder(path: str) -> str | None:
    """``pid N (command line)`` of the process holding a lock on ``path``, if Linux says."""
    try:
        st = os.stat(path)
        locks = Path("/proc/locks").read_text()
    except OSError:
        return None
    for line in locks.splitlines():
        fields = line.split()
        ids = [f for f in fields if f.count(":") == 2]
        if not ids or len(fields) < 5:
            continue
        major, minor, inode = ids[0].split(":")
        try:
            dev = os.makedev(int(major, 16), int(minor, 16))
            if int(inode) != st.st_ino or dev != st.st_dev:
                continue
            pid = fields[fields.index(ids[0]) - 1]
            cmd = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ")
        except (ValueError, OSError):
            continue
        return f"pid {pid} ({cmd.decode(errors='replace').strip()[:120]})"
    return None


class PortLock:
    """``with PortLock(port):`` holds the port's lock, or raises FlashError saying who has
    it. Ports that are not device files (``usb`` for a USB programmer) have nothing to lock."""

    def __init__(self, port: str) -> None:
        self.port = port
        self.fd: int | None = None

    def __enter__(self) -> PortLock:
        path = os.path.realpath(self.port)
        if not os.path.exists(path) or not Path(path).is_char_device():
            if "/" in self.port:
                raise FlashError(f"cannot open {self.port}: no such device (is the board "
                                 "plugged in? ls /dev/ttyUSB* /dev/ttyACM*)")
            return self
        try:
            self.fd = os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        except OSError as exc:
            raise FlashError(f"cannot open {self.port}: {exc.strerror}") from None
        try:
            fcntl.flock(self.fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(self.fd)
            self.fd = None
            who = holder(path)
            raise FlashError(f"{self.port} is in use: another program holds its lock"
                             + (f", {who}" if who else "")
                             + "; stop it (esair std run, esair monitor, a terminal) and "
                             "flash again") from None
        return self

    def __exit__(self, *exc: object) -> None:
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None
