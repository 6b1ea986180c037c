"""The emulated world's true state on a side channel (``esair emulate ROBOT --pty
--world-out SOCKET``), for the host's simulated sensors that must render from the
world the emulated robot lives in (ESAIR STD's STARFISH microphones, camera and radio;
docs/std-starfish.md).

Each central tick's true pose goes to ``SOCKET``, a Unix datagram socket the reader
has bound, as one ASCII datagram::

    pose <t_s> <x_mm> <y_mm> <theta_rad> <collisions>

The emulator never waits for its reader: a datagram is sent without blocking, and one
that cannot be sent now (no reader bound yet, its queue full) is dropped and counted
(``dropped``); the next tick's pose supersedes it. The robot's serial link is what the
host drives and reads; this channel is only the simulation's ground truth.
"""

from __future__ import annotations

import socket
from pathlib import Path


def pose_datagram(t_s: float, x: float, y: float, theta: float, collisions: int) -> bytes:
    return f"pose {t_s:.6f} {x:.2f} {y:.2f} {theta:.6f} {collisions}".encode("ascii")


def parse_datagram(data: bytes) -> tuple[float, float, float, float, int] | None:
    """(t_s, x_mm, y_mm, theta, collisions) of a ``pose`` datagram, None for anything else."""
    parts = data.split()
    if len(parts) != 6 or parts[0] != b"pose":
        return None
    try:
        return (float(parts[1]), float(parts[2]), float(parts[3]), float(parts[4]),
                int(parts[5]))
    except ValueError:
        return None


class WorldPublisher:
    """Sends poses to ``path`` without ever blocking the emulator."""

    def __init__(self, path: Path | str):
        self.path = str(path)
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        self.sock.setblocking(False)
        self.sent = 0
        self.dropped = 0

    def publish(self, t_s: float, x: float, y: float, theta: float, collisions: int) -> None:
        try:
            self.sock.sendto(pose_datagram(t_s, x, y, theta, collisions), self.path)
            self.sent += 1
        except OSError:          # no reader (yet), or its queue is full: the next one wins
            self.dropped += 1

    def close(self) -> None:
        self.sock.close()
