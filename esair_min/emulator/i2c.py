"""The I2C bus at its declared speed: bit counting, bus time and NACKs.

Every transaction is counted in bit times (time = bits / speed):

- write: START (1) + address byte and ACK (9) + each data byte and ACK (9) + STOP (1);
- write then read: START + address + the written bytes, repeated START (1) + address
  (9) + each read byte and ACK/NACK (9) + STOP;
- a device that does not acknowledge its address: START + address (9) + STOP;
- on a stuck bus (``stuck``): nothing reaches a device and each transaction fails
  after the master's timeout and bus clear (``stuck_ns``).

:class:`TimedBus` wraps the devices' bus (``write``/``write_read``, the core's ``Bus``
protocol), so the core cannot tell it from the real thing, and keeps a time cursor:
a transaction starts when both the virtual clock and the bus have reached its start,
and the bus is busy until its last bit.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Protocol

from esair_min.model.hardware import BYTE, RESTART, START, STOP, nack_bits, write_bits, write_read_bits
from esair_min.emulator.clock import NS_PER_S

__all__ = ["BYTE", "RESTART", "START", "STOP", "Bus", "BusStats", "TimedBus", "bits_ns", "transfer_ns",
           "nack_bits", "write_bits", "write_read_bits"]


class Bus(Protocol):
    def write(self, addr: int, data: bytes) -> bool: ...
    def write_read(self, addr: int, wdata: bytes, n: int) -> bytes | None: ...


def bits_ns(bits: int, speed_hz: int) -> int:
    return int(round(bits * NS_PER_S / speed_hz))


def transfer_ns(speed_hz: int, n_write: int, n_read: int | None,
                overhead_ns: Callable[[int, int | None], int] | None = None) -> int:
    """What the emulator charges for an acknowledged transfer: its wire bits at
    ``speed_hz`` plus the master's overhead (esair_min.model.mcu.bus_overhead_ns)."""
    bits = write_bits(n_write) if n_read is None else write_read_bits(n_write, n_read)
    return bits_ns(bits, speed_hz) + (overhead_ns(n_write, n_read) if overhead_ns else 0)


@dataclass
class BusStats:
    transactions: int = 0
    nacks: int = 0
    bits: int = 0
    by_address: dict[int, int] = field(default_factory=dict)   # bits per address


class TimedBus:
    """A :class:`Bus` that accounts bus time at ``speed_hz`` against a clock."""

    def __init__(self, inner: Bus, speed_hz: int, now: Callable[[], int],
                 stuck_ns: int = 0,
                 overhead_ns: Callable[[int, int | None], int] | None = None):
        self.inner = inner
        #: the master's cost beyond the wire per transfer (bytes written, read or None):
        #: esair_min.model.mcu.bus_overhead_ns for the central board's MCU and clock
        self.overhead_ns = overhead_ns
        self.speed_hz = speed_hz
        self._now = now
        #: SCL held low: no device is reached, every transaction fails after
        #: ``stuck_ns`` (the master's timeout and bus clear)
        self.stuck = False
        self.stuck_ns = stuck_ns
        self.busy_until = 0
        self.last_start = 0
        self.stats = BusStats()
        self._ns: dict[object, int] = {}   # transfer shape -> bus time, computed once
        self._nack_bits = nack_bits()

    def _account(self, addr: int, bits: int, ok: bool, n_write: int = 0,
                 n_read: int | None = None) -> None:
        now = self._now()
        start = self.busy_until if self.busy_until > now else now
        self.last_start = start
        if self.stuck:
            ns = self.stuck_ns
        else:
            key = (bits, n_write, n_read) if ok else bits
            ns = self._ns.get(key)
            if ns is None:
                ns = bits_ns(bits, self.speed_hz)
                if ok and self.overhead_ns is not None:
                    ns += self.overhead_ns(n_write, n_read)
                self._ns[key] = ns
        self.busy_until = start + ns
        st = self.stats
        st.transactions += 1
        st.bits += bits
        by = st.by_address
        by[addr] = by.get(addr, 0) + bits
        if not ok:
            st.nacks += 1

    def hold(self, until_ns: int) -> None:
        """The master starts nothing before ``until_ns``: the superloop that drives it
        is busy elsewhere (waiting for room in the UART transmit ring)."""
        if until_ns > self.busy_until:
            self.busy_until = until_ns

    def cursor(self) -> int:
        """When the bus is next free (never before now)."""
        now = self._now()
        return self.busy_until if self.busy_until > now else now

    def write(self, addr: int, data: bytes) -> bool:
        ok = not self.stuck and self.inner.write(addr, data)
        self._account(addr, write_bits(len(data)) if ok else self._nack_bits, ok, len(data))
        return ok

    def write_read(self, addr: int, wdata: bytes, n: int) -> bytes | None:
        got = None if self.stuck else self.inner.write_read(addr, wdata, n)
        ok = got is not None
        self._account(addr, write_read_bits(len(wdata), n) if ok else self._nack_bits, ok,
                      len(wdata), n)
        return got
