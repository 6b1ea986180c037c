"""The frame player and the balance reaction (docs/protocol.md), stepped per tick.

Both talk to the hardware only through a :class:`~esair_min.core.i2c_bus.Bus`; neither keeps
time other than the ticks it is stepped with.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal, Sequence

from esair_min.core.protocol import Code

if TYPE_CHECKING:
    from esair_min.core.i2c_bus import Bus


#: frames whose check is remembered (a motion replays the same few frames)
FRAME_CACHE = 1024


class Player:
    """A non-blocking frame player: one sequential EEPROM read per frame, one burst
    write to the actuator board per frame, on ticks."""

    def __init__(self, bus: Bus, eeprom: int, address_bytes: int, actuator: int,
                 limits: Sequence[tuple[int, int]], targets: list[int]):
        self.bus = bus
        self.eeprom = eeprom
        self.address_bytes = address_bytes
        self.actuator = actuator
        self.limits = tuple(limits)
        self.frame_bytes = 2 * len(self.limits)
        self.targets = targets          # the core's list, updated on every frame written
        self.playing: int | None = None
        self._frames = 0                # of the playing motion (its directory entry)
        self._delay = 0
        self._offset = 0
        self._next = 0                  # index of the frame held in _frame
        self._frame: bytes = b""
        self._wait = 0                  # ticks until the held frame is written
        self._checked: dict[bytes, tuple[list[int], bytes] | Literal[False]] = {}   # frame -> _check

    def stop(self) -> None:
        """End the motion at once; a frame already read is dropped."""
        self.playing = None
        self._frame = b""

    def start(self, number: int, frames: int, delay: int, offset: int) -> bool:
        """Read the first frame of motion ``number`` (its directory entry: frames, delay
        in ticks, offset of its first frame); False (and idle) if the read failed.
        The frame is written at the next tick."""
        self.stop()
        self._frames, self._delay, self._offset = frames, delay, offset
        self.playing = number
        self._next = 0
        if not self._read():
            self.stop()
            return False
        self._wait = 1
        return True

    def _read(self) -> bool:
        addr = (self._offset + self._next * self.frame_bytes) & 0xFFFF
        data = self.bus.write_read(self.eeprom, addr.to_bytes(self.address_bytes, "big"),
                                   self.frame_bytes)
        if data is None or len(data) != self.frame_bytes:
            return False
        self._frame = bytes(data)
        return True

    def _check(self, frame: bytes) -> tuple[list[int], bytes] | Literal[False]:
        """A frame's angles and its burst write, or False if a pair does not decode or
        lies outside its servo's limits."""
        angles = []
        for i, (lo, hi) in enumerate(self.limits):
            low = frame[2 * i]
            angle = (frame[2 * i + 1] % 10) * 100 + low
            if low >= 100 or not lo <= angle <= hi:
                return False
            angles.append(angle)
        return angles, b"\x00" + frame

    def step(self) -> Code | None:
        """One tick. Returns the code of a notice when the motion stopped on an error."""
        if self.playing is None:
            return None
        self._wait = (self._wait - 1) & 0xFF      # a byte, as in the C (delay 0: 256 ticks)
        if self._wait:
            return None
        frame = self._frame
        checked = self._checked.get(frame)
        if checked is None:
            if len(self._checked) >= FRAME_CACHE:
                self._checked.clear()
            checked = self._checked[frame] = self._check(frame)
        if checked is False:
            self.stop()
            return Code.OUTSIDE_LIMITS
        angles, burst = checked
        if not self.bus.write(self.actuator, burst):
            self.stop()
            return Code.NO_ANSWER
        self.targets[:] = angles
        self._next += 1
        if self._next >= self._frames:
            self.stop()
            return None
        if not self._read():
            self.stop()
            return Code.NO_ANSWER
        self._wait = self._delay
        return None


class BalanceReaction:
    """Compare two sensor groups every ``poll_ticks`` ticks; fire after ``samples``
    consecutive tipping samples."""

    def __init__(self, name: str, group_a: Sequence[int], group_b: Sequence[int],
                 threshold: int, samples: int, poll_ticks: int, motion: int):
        self.name = name
        self.group_a = tuple(group_a)    # sensor indices (register order)
        self.group_b = tuple(group_b)
        self.threshold = threshold
        self.samples = samples
        self.poll_ticks = poll_ticks
        self.motion = motion
        self.count = 0
        self.failing = False             # the sensor board stopped answering its polls

    def due(self, tick: int, playing: int | None) -> bool:
        """Poll on ticks that are multiples of ``poll_ticks``, unless its motion plays."""
        return tick % self.poll_ticks == 0 and playing != self.motion

    def failed(self) -> bool:
        """A poll was not answered: True if a notice is due (the first failure)."""
        self.count = 0
        first = not self.failing
        self.failing = True
        return first

    def sample(self, values: Sequence[int]) -> bool:
        """One answered poll; True when the reaction fires (the count restarts)."""
        self.failing = False
        a = sum(values[i] for i in self.group_a)
        b = sum(values[i] for i in self.group_b)
        if abs(a - b) > self.threshold:
            self.count += 1
            if self.count >= self.samples:
                self.count = 0
                return True
        else:
            self.count = 0
        return False
