"""The central board's UART at line rate, both directions.

A byte takes 10 bit times (start, 8 data, stop) at the declared baud. Bytes written by
the host are shifted in one after another; when one is complete it goes into the
board's 64-byte receive ring (the PIC port's interrupt-fed ring). A byte that finds the
ring full is dropped and the overrun flag is set (docs/trace-format.md). Bytes the
board sends are shifted out one after another and reach the host when complete.
"""

from __future__ import annotations

from collections import deque
from typing import Callable

from .clock import NS_PER_S, VirtualClock

RING_BYTES = 64


def byte_time_ns(baud: int) -> int:
    """Time of one 8N1 character: 10 bit times."""
    return int(round(10 * NS_PER_S / baud))


class Uart:
    """Line-rate UART. ``on_rx`` is called after each byte lands in the ring."""

    def __init__(self, clock: VirtualClock, baud: int, on_rx: Callable[[], None]):
        self.clock = clock
        self.baud = baud
        self.byte_ns = byte_time_ns(baud)
        self._on_rx = on_rx
        # host -> board
        self._rx_wire: deque[tuple[int, int]] = deque()   # (arrival ns, byte)
        self._rx_free = 0                                  # wire idle from this time
        self.ring: deque[int] = deque()
        self.overrun = False
        self.overruns = 0
        self.rx_bytes = 0
        # board -> host
        self._tx_wire: deque[tuple[int, int]] = deque()   # (delivery ns, byte)
        self._tx_free = 0
        self._host_buf = bytearray()                       # delivered, not read yet
        self.tx_bytes = 0

    # --- host -> board -------------------------------------------------------------
    def host_write(self, data: bytes) -> None:
        """The host starts sending ``data`` now (queued behind bytes still on the wire)."""
        if not data:
            return
        now = self.clock.now
        t = self._rx_free if self._rx_free > now else now
        was_idle = not self._rx_wire
        wire = self._rx_wire
        step = self.byte_ns
        for b in data:
            t += step
            wire.append((t, b))
        self._rx_free = t
        if was_idle:
            self.clock.schedule(wire[0][0], self._rx_arrive)

    def _rx_arrive(self) -> None:
        wire, ring, clock, on_rx = self._rx_wire, self.ring, self.clock, self._on_rx
        while True:
            now = clock.now
            while wire and wire[0][0] <= now:
                b = wire.popleft()[1]
                self.rx_bytes += 1
                if len(ring) >= RING_BYTES:
                    self.overrun = True
                    self.overruns += 1
                else:
                    ring.append(b)
            on_rx()
            if not wire:
                return
            # the next byte: handled here if nothing else happens before it
            if not clock.advance_inline(wire[0][0]):
                clock.schedule(wire[0][0], self._rx_arrive)
                return

    def receive(self, b: int) -> None:
        """A complete byte reaches the receive ring (or is lost to an overrun)."""
        self.rx_bytes += 1
        if len(self.ring) >= RING_BYTES:
            self.overrun = True
            self.overruns += 1
        else:
            self.ring.append(b)

    @property
    def rx_free_ns(self) -> int:
        """When the last byte the host wrote will have reached the board."""
        return max(self._rx_free, self.clock.now)

    @property
    def rx_idle(self) -> bool:
        """Nothing on the wire towards the board and nothing waiting in the ring."""
        return not self._rx_wire and not self.ring

    # --- board -> host -------------------------------------------------------------
    def board_send(self, data: bytes, at_ns: int) -> None:
        """The board starts sending ``data`` at ``at_ns`` (behind earlier output)."""
        t = self._tx_free if self._tx_free > at_ns else at_ns
        wire = self._tx_wire
        step = self.byte_ns
        for b in data:
            t += step
            wire.append((t, b))
        self._tx_free = t
        self.tx_bytes += len(data)

    def _deliver(self) -> None:
        wire = self._tx_wire
        if wire and wire[0][0] <= self.clock.now:
            now = self.clock.now
            out = self._host_buf
            while wire and wire[0][0] <= now:
                out.append(wire.popleft()[1])

    def host_read(self) -> bytes:
        """Every byte that has completely reached the host by now (and was not read)."""
        self._deliver()
        if not self._host_buf:
            return b""
        out = bytes(self._host_buf)
        self._host_buf.clear()
        return out

    def tx_next(self) -> int | None:
        """When the next byte reaches the host, or None when nothing is being sent."""
        self._deliver()
        return self._tx_wire[0][0] if self._tx_wire else None

    @property
    def tx_idle(self) -> bool:
        """Nothing still being sent to the host (bytes delivered but unread do not count)."""
        self._deliver()
        return not self._tx_wire
