"""Opening a robot's serial port, for every ESAIR program that talks to one.

A port is opened *exclusively*: pySerial takes an advisory ``flock`` on the device, so a
second ESAIR program (another ``esair send``, a runtime's link reconnecting to a
``/dev/pts/N`` that now belongs to someone else) is refused at once instead of writing
into another program's robot and reading half of its replies (docs/protocol.md).
``esair://`` URLs (the in-process emulator) have nothing to lock.
"""

from __future__ import annotations

from typing import Any

#: pySerial's words for a port that cannot be used, and a user's.
PLAIN = {"device reports readiness to read but returned no data":
         "the device disconnected (unplugged, or another program uses the port)",
         "[Errno 5] Input/output error": "input/output error (the device unplugged?)",
         "[Errno 11] Could not exclusively lock port":
         "another program has the port open (it holds the port's lock)"}


#: What :func:`describe` says of a port another ESAIR program holds.
LOCKED = PLAIN["[Errno 11] Could not exclusively lock port"]


def describe(exc: BaseException) -> str:
    """A user's words for a pySerial error."""
    text = str(exc) or type(exc).__name__
    return next((plain for raw, plain in PLAIN.items() if text.startswith(raw)), text)


#: The kernel's majors of UNIX 98 pty slaves (/dev/pts/N).
_PTY_MAJORS = range(136, 144)

#: What tells one pty from another on the same path: see :func:`pty_identity`.
PtyIdentity = tuple[int, int, int, int]


def pty_identity(path: str) -> PtyIdentity | None:
    """The pty ``path`` leads to, told apart from the next pty the kernel gives the same
    number: (the symlink's inode and change time if ``path`` is one, else 0 and 0; the
    pty's device number; its creation time: a /dev/pts node is made afresh for each
    pty). None if ``path`` does not lead to a pty (a USB adapter, a missing path)."""
    import os
    import stat

    try:
        link = os.lstat(path)
        node = os.stat(path)
    except OSError:
        return None
    if not stat.S_ISCHR(node.st_mode) or os.major(node.st_rdev) not in _PTY_MAJORS:
        return None
    own = (link.st_ino, link.st_ctime_ns) if stat.S_ISLNK(link.st_mode) else (0, 0)
    return (*own, node.st_rdev, node.st_ctime_ns)


def stale_pty(was: PtyIdentity | None, now: PtyIdentity | None) -> bool:
    """``path`` (``was`` when last opened, ``now`` today) leads to the same pty number
    through the same symlink (or none), but a pty made since: another program's, since
    the one opened then went away. A symlink made anew (an emulator restarted and
    pointed it at its new pty) is trusted."""
    return was is not None and now is not None and was[:3] == now[:3] and was[3] != now[3]


def open_port(url: str, lock_wait: float = 0.0, **settings: Any) -> Any:
    """A pySerial port for a device path or a URL (``esair://`` included), locked against
    other ESAIR programs; pySerial's exceptions pass through (see :func:`describe`). A
    lock another program holds is tried again for ``lock_wait`` seconds: a runtime's
    link reconnecting to a pty number that is now this robot's holds it only for its
    probe (a ``v`` or two), then lets go."""
    import time

    import serial

    if url.startswith("esair://"):   # the emulator is big: only its own URLs import it
        import esair_min.emulator  # noqa: F401  (registers the esair:// URL scheme)

    if "://" not in url:
        settings.setdefault("exclusive", True)
    deadline, pause = time.monotonic() + lock_wait, 0.02
    while True:
        try:
            return serial.serial_for_url(url, **settings)
        except serial.SerialException as exc:
            left = deadline - time.monotonic()
            if describe(exc) != LOCKED or left <= 0:
                raise
            time.sleep(min(pause, left))
            pause *= 2
