"""The emulated world's side channel: :mod:`esair_min.world.out` (the host's reader
imports it without the emulator), named here where the emulator sends it."""

from esair_min.world.out import WorldPublisher, parse_datagram, pose_datagram

__all__ = ["WorldPublisher", "parse_datagram", "pose_datagram"]
