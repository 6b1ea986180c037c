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
