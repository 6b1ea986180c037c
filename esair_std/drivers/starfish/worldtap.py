"""The emulated world's true pose, as the emulator publishes it (``esair emulate
starfish --pty --world-out SOCKET``, esair_min/emulator/world_out.py): the microphones,
the camera and the radio render from the world the emulated robot lives in, never
from the odometry the behaviors see.

:class:`WorldTap` binds the Unix datagram socket (in a private temporary folder) before
the emulator starts, and a thread keeps the latest pose. Until the first datagram the
pose is the start pose the emulator was given. Datagrams that are not a pose are
counted (``bad``); the emulator counts what it could not send.
"""

from __future__ import annotations

import contextlib
import os
import socket
import tempfile
import threading

from esair_min.world.out import parse_datagram


class WorldTap:
    def __init__(self, start: tuple[float, float, float]):
        self._dir = tempfile.TemporaryDirectory(prefix="esair-world-")
        self.path = os.path.join(self._dir.name, "world.sock")
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        self.sock.bind(self.path)
        self.sock.settimeout(0.2)
        self.start = start
        self._pose = start                  # x m, y m, theta rad
        self.t_s = 0.0                      # the emulator's virtual time of that pose
        self.collisions = 0
        self.received = 0
        self.bad = 0
        self.fresh = threading.Event()      # set at each pose received
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="starfish-world", daemon=True)
        self._thread.start()

    def pose(self) -> tuple[float, float, float]:
        return self._pose

    def restart(self) -> None:
        """The emulator starts again (its world from the start pose)."""
        self._pose = self.start
        self.fresh.clear()

    def _run(self) -> None:
        _name_os_thread(b"starfish-world")
        while not self._stop.is_set():
            try:
                data = self.sock.recv(256)
            except TimeoutError:
                continue
            except OSError:
                return                      # closed
            got = parse_datagram(data)
            if got is None:
                self.bad += 1
                continue
            t, x, y, th, hits = got
            self._pose = (x / 1000.0, y / 1000.0, th)   # one assignment: readers see a whole pose
            self.t_s, self.collisions = t, hits
            self.received += 1
            self.fresh.set()

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2)
        with contextlib.suppress(OSError):
            self.sock.close()
        self._dir.cleanup()


def _name_os_thread(name: bytes) -> None:
    """The calling thread's name as the OS shows it (/proc/PID/task/TID/comm): this
    simulation plumbing told apart from the robot's own work (bench/small_computer.py)."""
    import ctypes                           # loaded already: numpy imports it
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None).prctl(15, name[:15], 0, 0, 0)     # PR_SET_NAME
