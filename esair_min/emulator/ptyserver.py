"""Serve an emulated robot on a pseudo-terminal, paced by the wall clock.

``serve_pty`` opens a pty pair (raw mode), reports the slave's path, then shuttles
bytes between the master side and the emulator until ``stop()`` returns True.

Like a real serial line, the port only carries bytes while a program has it open:
what the robot sends while nobody has the port open is dropped (counted in
:attr:`PtyPort.dropped`), and what a program left unread when it closed the port is
discarded, so a program opening the port late never reads old notices. The robot has
booted when the path is printed, and its boot notice (``!READY``) went to nobody: the
first program that opens the port never reads it either (always the same, however soon
it opens). The server does not keep the slave side open itself (the kernel then tells
it, by POLLHUP on the master, whether any program has); programs may open and close
the port as often as they like. When it discards unread bytes it first sets the line
to wait for a byte (VMIN 1), so a program it races with gets "nothing yet", never an
empty read (pySerial raises on one).

A robot does not read its line while it has no power: when the server itself did not
run for more than :data:`STALL_S` (the process was stopped, SIGSTOP), the bytes that
programs wrote meanwhile are dropped, not played late (counted in
:attr:`PtyPort.stale`), as they would be lost on a wire to a robot switched off.
"""

from __future__ import annotations

import math
import os
import select
import termios
import time
import tty
from dataclasses import dataclass
from typing import Callable

from esair_min.emulator.pacing import Pacer
from esair_min.emulator.line import SerialHost

#: Longest wait between two looks at the port while nothing is due (s).
IDLE_POLL_S = 0.02
#: Wait before trying again to hand the program bytes the pty had no room for (s).
WRITE_RETRY_S = 0.002
#: A pause of the server longer than this (s) is a robot without power: what programs
#: wrote meanwhile is dropped.
STALL_S = 1.0


@dataclass
class PtyPort:
    """The port's state, for a display: its path, whether a program has it open, and
    how many bytes the robot sent while none had."""

    path: str = ""
    open: bool = False
    dropped: int = 0
    opened: int = 0          # how many times a program opened it
    stale: int = 0           # bytes programs wrote while the server was stopped: dropped
    garbled: int = 0         # bytes that crossed at a baud other than the robot's


#: termios speed codes -> bauds (the port's setting, which a pty keeps but ignores)
_SPEEDS = {getattr(termios, f"B{n}"): n for n in
           (1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200, 230400)}


def _garbled(data: bytes) -> bytes:
    """What a UART makes of bytes sent at another baud: framing errors and wrong bytes,
    never a line end (modelled: each byte with its top bit set)."""
    return bytes((b ^ 0xA5) | 0x80 for b in data)


def _port_baud(master: int) -> int | None:
    """The baud the program set on the port (None: one not in the table)."""
    try:
        return _SPEEDS.get(termios.tcgetattr(master)[5])
    except termios.error:
        return None


def open_pty() -> tuple[int, int, str]:
    """(master fd, slave fd, slave path) of a new pseudo-terminal in raw mode."""
    master, slave = os.openpty()
    tty.setraw(slave)
    os.set_blocking(master, False)
    return master, slave, os.ttyname(slave)


def _discard_unread(path: str) -> None:
    """Drop what the robot sent that the last program did not read before closing."""
    try:
        fd = os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    except OSError:
        return
    try:
        attrs = termios.tcgetattr(fd)
        attrs[6][termios.VMIN], attrs[6][termios.VTIME] = 1, 0
        termios.tcsetattr(fd, termios.TCSANOW, attrs)   # a racing read waits, never empty
        termios.tcflush(fd, termios.TCIFLUSH)
    except termios.error:
        pass
    finally:
        os.close(fd)


def serve_pty(emu: SerialHost, on_path: Callable[[str], None],
              stop: Callable[[], bool], factor: float = 1.0,
              on_idle: Callable[[], None] | None = None,
              port: PtyPort | None = None, baud: int | None = None) -> None:
    """Run ``emu`` in real time behind a pty until ``stop()``; ``on_idle`` runs each loop;
    ``port`` (if given) is kept up to date. With ``baud`` (the robot's), bytes cross
    garbled both ways while the program's port is set to another baud, as on a wire."""
    master, slave, path = open_pty()
    os.close(slave)            # a program opening the port is then visible (no POLLHUP)
    port = PtyPort() if port is None else port
    port.path = path
    emu.settle()               # the robot has booted (image checked, !READY sent) when the
    port.dropped += len(emu.read())   # port appears: a program may write at once, and
    pacer = Pacer(emu, factor)        # never reads the boot notice (it went to nobody)
    poller = select.poll()
    poller.register(master, select.POLLIN)
    pending = bytearray()
    try:
        last = time.monotonic()            # before the path shows: a stop from then on counts
        on_path(path)
        while not stop():
            pacer.sync()
            events = dict(poller.poll(0)).get(master, 0)
            was_open, port.open = port.open, not events & select.POLLHUP
            if was_open and not port.open:
                _discard_unread(path)
            elif port.open and not was_open:
                port.opened += 1
            data = _read(master) if events & select.POLLIN else b""
            # checked after the read: a stop anywhere since the last check shows here
            now = time.monotonic()
            if now - last > STALL_S:             # stopped: the robot had no power
                port.stale += len(data)
                data = b""
                while stale := _read(master):
                    port.stale += len(stale)
            last = now
            wrong = baud is not None and port.open and _port_baud(master) != baud
            if data and wrong:
                port.garbled += len(data)
                data = _garbled(data)
            if data:
                # input first: its bytes start on the wire now, and the sleep below
                # must already know when they (and the reply) next need a look
                emu.write(data)
            pending += emu.read()
            if not port.open:
                port.dropped += len(pending)      # nobody listens: lost, as on a wire
                pending.clear()
            elif pending:
                if wrong:
                    port.garbled += len(pending)
                    pending[:] = _garbled(bytes(pending))
                try:
                    n = os.write(master, pending)
                    del pending[:n]
                except (BlockingIOError, InterruptedError):
                    pass
                except OSError:                  # the program closed the port meanwhile
                    port.dropped += len(pending)
                    pending.clear()
            if on_idle is not None:
                on_idle()
            wait = WRITE_RETRY_S if pending else pacer.wall_until_next(IDLE_POLL_S)
            if wait > 0:
                # select: microsecond timeouts (poll's are whole ms: a byte is ~1 ms)
                _sleep(master if port.open else None, wait, poller)
    finally:
        os.close(master)


def _sleep(fd: int | None, wait: float, poller: "select.poll") -> None:
    """Sleep ``wait`` seconds or until ``fd`` (if given) is readable. select() takes
    microseconds (poll() whole milliseconds, and a byte at 9600 baud is ~1 ms); poll(),
    rounded up, only for a descriptor beyond select()'s reach."""
    try:
        select.select([] if fd is None else [fd], [], [], wait)
    except ValueError:                           # fd >= FD_SETSIZE
        if fd is None:
            time.sleep(wait)
        else:
            poller.poll(math.ceil(wait * 1000))
    except InterruptedError:
        pass


def _read(master: int) -> bytes:
    """What the program wrote (also after it closed the port: the kernel keeps it)."""
    try:
        return os.read(master, 4096)
    except (BlockingIOError, InterruptedError):
        return b""
    except OSError:            # EIO: nobody has the port open and nothing is left
        return b""
