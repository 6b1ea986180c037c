"""Serve an emulated robot on a pseudo-terminal, paced by the wall clock.

``serve_pty`` opens a pty pair (raw mode), reports the slave's path, then shuttles
bytes between the master side and the emulator until ``stop()`` returns True. The
server keeps its own handle on the slave, so clients may open and close the port as
often as they like. Output written while no client listens waits in the pty (up to
``MAX_PENDING`` bytes, then the oldest is dropped, as a wire nobody listens to).
"""

from __future__ import annotations

import os
import select
import tty
from typing import Callable

from esair_min.emulator.pacing import Pacer
from esair_min.emulator.robot import Emulator

MAX_PENDING = 65536


def open_pty() -> tuple[int, int, str]:
    """(master fd, slave fd, slave path) of a new pseudo-terminal in raw mode."""
    master, slave = os.openpty()
    tty.setraw(slave)
    os.set_blocking(master, False)
    return master, slave, os.ttyname(slave)


def serve_pty(emu: Emulator, on_path: Callable[[str], None],
              stop: Callable[[], bool], factor: float = 1.0,
              on_idle: Callable[[], None] | None = None) -> None:
    """Run ``emu`` in real time behind a pty until ``stop()``; ``on_idle`` runs each loop."""
    master, slave, path = open_pty()
    emu.settle()               # the robot has booted (image checked, !READY sent) when the
    pacer = Pacer(emu, factor)  # port appears: a program may write at once
    pending = bytearray()
    try:
        on_path(path)
        while not stop():
            pacer.sync()
            pending += emu.read()
            if len(pending) > MAX_PENDING:
                del pending[:len(pending) - MAX_PENDING]
            if pending:
                try:
                    n = os.write(master, pending)
                    del pending[:n]
                except (BlockingIOError, InterruptedError):
                    pass
            wait = 0.002 if pending else pacer.wall_until_next(0.02)
            try:
                ready, _, _ = select.select([master], [], [], wait)
            except InterruptedError:
                continue
            if ready:
                try:
                    data = os.read(master, 4096)
                except (BlockingIOError, InterruptedError):
                    data = b""
                except OSError:       # EIO: no client; we hold the slave, so rare
                    data = b""
                if data:
                    pacer.sync()
                    emu.write(data)
            if on_idle is not None:
                on_idle()
    finally:
        os.close(master)
        os.close(slave)
