"""The actuator board: a register map latched on the sync pin, and the servo model.

Registers ``2m``/``2m+1`` hold servo m's ``low = angle % 100`` and
``high = angle/100 + 10*speed`` (docs/protocol.md). On each sync tick the board latches
the whole map: every servo takes the decoded angle as its target and the decoded speed
as its speed, then moves toward the target by *speed* degrees (speed 0: at once).
Targets are clamped to the servo's limits, as the actuator firmware does; a pair that
does not decode (``low >= 100``) or lies outside the limits is counted as an error.
"""

from __future__ import annotations

from typing import MutableSequence, Sequence

from esair_min.model.board import Servo
from esair_min.model.encoding import decode_pair, encode_pair


#: (low, high) register pair of an angle and speed, and back (the model's encoding)
encode = encode_pair
decode = decode_pair


def step_toward(angle: int, target: int, speed: int) -> int:
    """One sync tick of a servo: move by ``speed`` degrees toward ``target`` (0: at once)."""
    if speed == 0 or abs(target - angle) <= speed:
        return target
    return angle + speed if target > angle else angle - speed


class ServoBank:
    """Angles, targets and speeds of a set of servos, stepped one sync tick at a time."""

    #: register maps and steps remembered (a dance repeats the same few of each)
    CACHE = 4096

    def __init__(self, servos: Sequence[Servo]):
        self.servos = tuple(servos)
        self.angles = [s.stand_angle for s in self.servos]
        self.targets = [s.stand_angle for s in self.servos]
        self.speeds = [s.default_speed for s in self.servos]
        self.bad_pairs = 0
        self._decoded: dict[bytes, tuple[list[int], list[int], int]] = {}
        self._steps: dict[tuple, list[int]] = {}      # (angles, targets, speeds) -> angles
        self._pairs = tuple((2 * s.index, s.min_angle, s.max_angle) for s in self.servos)

    def _decode(self, regs: Sequence[int]) -> tuple[list[int], list[int], int]:
        """Targets, speeds and the number of bad pairs of a register map."""
        targets, speeds, bad = [], [], 0
        for at, lo, hi in self._pairs:
            low, high = regs[at], regs[at + 1]
            angle, speed = decode(low, high)
            if low >= 100 or not lo <= angle <= hi:
                bad += 1
                angle = min(max(angle, lo), hi)
            targets.append(angle)
            speeds.append(speed)
        return targets, speeds, bad

    def latch(self, regs: Sequence[int]) -> None:
        """Take new targets and speeds from a register map (2 bytes per servo)."""
        key = regs if type(regs) is bytes else bytes(regs)
        got = self._decoded.get(key)
        if got is None:
            if len(self._decoded) >= self.CACHE:
                self._decoded.clear()
            got = self._decoded[key] = self._decode(key)
        targets, speeds, bad = got
        self.targets[:] = targets
        self.speeds[:] = speeds
        self.bad_pairs += bad

    def step(self) -> None:
        a, t, v = self.angles, self.targets, self.speeds
        if a == t:                   # every servo at its target (one C-level compare)
            return
        key = (tuple(a), tuple(t), tuple(v))     # a dance repeats the same steps
        after = self._steps.get(key)
        if after is None:
            if len(self._steps) >= self.CACHE:
                self._steps.clear()
            after = self._steps[key] = [step_toward(*s) for s in zip(a, t, v)]
        a[:] = after


def stand_registers(servos: Sequence[Servo]) -> bytes:
    """The register map the actuator firmware starts with: the stand pose at default speed."""
    n = max((s.index for s in servos), default=-1) + 1
    regs = bytearray(2 * n)
    for s in servos:
        regs[2 * s.index], regs[2 * s.index + 1] = encode(s.stand_angle, s.default_speed)
    return bytes(regs)


class ActuatorBoard:
    """The actuator board: latches ``regs`` (its live register map) on each sync tick."""

    def __init__(self, servos: Sequence[Servo], regs: MutableSequence[int]):
        self.regs = regs
        self.bank = ServoBank(servos)
        self.syncs = 0
        self._latched: bytes | None = None

    def sync(self) -> None:
        self.syncs += 1
        snapshot = bytes(self.regs)
        if snapshot != self._latched:       # same map, same targets: nothing to decode
            self._latched = snapshot
            self.bank.latch(snapshot)
        self.bank.step()

    @property
    def angles(self) -> list[int]:
        return list(self.bank.angles)

    @property
    def targets(self) -> list[int]:
        return list(self.bank.targets)
