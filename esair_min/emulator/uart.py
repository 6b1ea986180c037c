"""The central board's UART at line rate, both directions.

A byte takes 10 bit times (start, 8 data, stop) at the declared baud. Bytes written by
the host are shifted in one after another; when one is complete it goes into the
board's 64-byte receive ring (the PIC port's interrupt-fed ring). A byte that finds the
ring full is dropped, and the next byte that gets in carries the mark :data:`GAP`
(bytes were lost just before it: docs/trace-format.md), so the board knows where the
loss is, not just that there was one. Bytes the
board sends are shifted out one after another and reach the host when complete;
:meth:`Uart.board_send` says when the board's 80-byte transmit ring had room for the
last of them (the superloop waits for room, so output faster than the line stalls it).

Bytes on the wire are kept as the chunks they were written in, ``(t0, data)``: byte
``i`` of a chunk is complete at ``t0 + (i + 1) * byte_ns``, exactly as if each had been
scheduled on its own.

Fast paths: before handling a byte the UART asks the board ``rx_mode()``:

- ``RX_TAKE``: the board would feed a byte arriving now straight to its decoder (ready,
  bus free). If the ring is empty and no overrun is pending, the bytes up to and
  including the first CR or LF, as far as the next pending event, go to ``direct(run)``
  (not through the ring), time moving on to the last one's completion;
- ``RX_HOLD``: the board will not touch the ring before its next pending event (it is
  not ready, or busy on the bus with a feed already scheduled): every byte complete
  before that event lands in the ring (or is lost to an overrun) at once;
- ``RX_BYTE``: the bytes complete now land in the ring, then ``on_rx()``.

The board's contract is that bytes other than CR and LF change nothing but its line
buffer, and nothing can observe the line buffer or the ring between two events, so
each fast path gives the same result as landing each byte at its own time.
"""

from __future__ import annotations

from collections import deque
from typing import Callable

from esair_min.core.protocol import RX_RING, TX_RING
from esair_min.emulator.clock import NS_PER_S, VirtualClock

RING_BYTES = RX_RING
GAP = 0x100                             # ring mark: bytes were lost just before this one
RX_BYTE, RX_TAKE, RX_HOLD = 0, 1, 2     # answers of ``rx_mode`` (see above)


def byte_time_ns(baud: int) -> int:
    """Time of one 8N1 character: 10 bit times."""
    return int(round(10 * NS_PER_S / baud))


class Uart:
    """Line-rate UART. ``on_rx`` is called after bytes land in the ring; ``rx_mode``
    and ``direct`` enable the fast paths described above."""

    def __init__(self, clock: VirtualClock, baud: int, on_rx: Callable[[], None],
                 rx_mode: Callable[[], int] | None = None,
                 direct: Callable[[bytes], None] | None = None, tx_ring: int = TX_RING):
        self.clock = clock
        self.tx_ring = tx_ring            # the board's transmit ring (protocol.TX_RING*)
        self.baud = baud
        self.byte_ns = byte_time_ns(baud)
        self._on_rx = on_rx
        self._rx_mode = rx_mode
        self._direct = direct
        # host -> board
        self._rx_wire: deque[tuple[int, bytes]] = deque()  # chunks (t0, data)
        self._rx_pos = 0                                   # next byte of the first chunk
        self._rx_free = 0                                  # wire idle from this time
        self.ring: deque[int] = deque()                    # at most RING_BYTES, GAP marks
        self.overrun = False            # bytes lost since the last one got into the ring
        self.overruns = 0               # bytes lost in all
        self.dropped: list[int] | None = None   # set to [] to keep which (tests)
        self.rx_bytes = 0
        # board -> host
        self._tx_wire: deque[tuple[int, bytes]] = deque()  # chunks (t0, data)
        self._tx_pos = 0
        self._tx_free = 0
        self._host_buf = bytearray()                       # delivered, not read yet
        self.tx_bytes = 0
        #: Told when the first line end (LF) of each output reaches the host.
        self.on_line_out: Callable[[int], None] | None = None

    # --- host -> board -------------------------------------------------------------
    def host_write(self, data: bytes) -> None:
        """The host starts sending ``data`` now (queued behind bytes still on the wire)."""
        if not data:
            return
        now = self.clock.now
        t = self._rx_free if self._rx_free > now else now
        was_idle = not self._rx_wire
        self._rx_wire.append((t, bytes(data)))
        self._rx_free = t + len(data) * self.byte_ns
        if was_idle:
            self.clock.schedule(t + self.byte_ns, self._rx_arrive)

    def _land(self, until: int) -> int:
        """Every byte on the wire complete at ``until`` goes into the ring (or is lost
        to an overrun), in order; returns the completion time of the last (or -1)."""
        wire, ring, step = self._rx_wire, self.ring, self.byte_ns
        last_t = -1
        while wire:
            t0, data = wire[0]
            pos = self._rx_pos
            end = (until - t0) // step              # bytes of this chunk complete by then
            if end <= pos:
                break
            if end > len(data):
                end = len(data)
            n = end - pos
            index0 = self.rx_bytes - pos        # data[k] is byte index0 + k of the stream
            self.rx_bytes += n
            room = RING_BYTES - len(ring)
            if room > 0 and self.overrun:         # the first byte in after a loss
                ring.append(data[pos] | GAP)
                self.overrun = False
                pos += 1
                n -= 1
                room -= 1
            if n <= room:
                ring.extend(data[pos:end])
            else:
                if room > 0:
                    ring.extend(data[pos:pos + room])
                self.overrun = True
                self.overruns += n - max(room, 0)
                if self.dropped is not None:
                    self.dropped.extend(range(index0 + pos + max(room, 0), index0 + end))
            last_t = t0 + end * step
            if end < len(data):
                self._rx_pos = end
                break
            wire.popleft()
            self._rx_pos = 0
        return last_t

    def _rx_arrive(self) -> None:
        """Runs when the first byte on the wire is complete; handles the following ones
        inline while nothing else happens before them."""
        wire, clock, step = self._rx_wire, self.clock, self.byte_ns
        rx_mode, direct = self._rx_mode, self._direct
        while True:
            now = clock.now
            mode = RX_BYTE if rx_mode is None else rx_mode()
            if mode == RX_TAKE and not self.ring and not self.overrun:
                horizon = clock.inline_limit()
                t0, data = wire[0]
                pos = self._rx_pos
                end = (horizon - t0) // step if horizon > now else (now - t0) // step
                if end > len(data):
                    end = len(data)
                cr = data.find(13, pos, end)        # the run stops after a line end
                if cr >= 0:
                    end = cr + 1
                lf = data.find(10, pos, end)
                if lf >= 0:
                    end = lf + 1
                if end >= len(data):
                    wire.popleft()
                    self._rx_pos = 0
                else:
                    self._rx_pos = end
                self.rx_bytes += end - pos
                t = t0 + end * step                 # the run's last byte is complete
                if t > now:
                    clock.advance_inline(t)         # within the horizon: always allowed
                direct(data[pos:end])               # type: ignore[misc]
            elif mode == RX_HOLD:
                horizon = clock.inline_limit()
                t = self._land(horizon if horizon > now else now)
                if t > now:
                    clock.advance_inline(t)         # (on_rx would do nothing: skipped)
            else:
                self._land(now)
                self._on_rx()
            if not wire:
                return
            # the next byte: handled here if nothing else happens before it
            t0 = wire[0][0]
            t = t0 + (self._rx_pos + 1) * step
            if t > clock.now and not clock.advance_inline(t):
                clock.schedule(t, self._rx_arrive)
                return

    def receive(self, b: int) -> None:
        """A complete byte reaches the receive ring (or is lost to an overrun)."""
        self.rx_bytes += 1
        if len(self.ring) >= RING_BYTES:
            self.overrun = True
            self.overruns += 1
            if self.dropped is not None:
                self.dropped.append(self.rx_bytes - 1)
        else:
            self.ring.append(b | GAP if self.overrun else b)
            self.overrun = False

    @property
    def rx_free_ns(self) -> int:
        """When the last byte the host wrote will have reached the board."""
        now = self.clock.now
        return self._rx_free if self._rx_free > now else now

    @property
    def rx_idle(self) -> bool:
        """Nothing on the wire towards the board and nothing waiting in the ring."""
        return not self._rx_wire and not self.ring

    # --- board -> host -------------------------------------------------------------
    def board_send(self, data: bytes, at_ns: int) -> int:
        """The board puts ``data`` into its transmit ring at ``at_ns``, behind earlier
        output; returns when the last byte found room there.

        A byte leaves the ring for TXREG when the byte before it starts shifting out,
        so byte ``b`` finds room once byte ``b - (TX_RING - 1)`` has left: ``TX_RING``
        byte times before ``b`` itself starts (the ring keeps one slot free).
        """
        t = self._tx_free if self._tx_free > at_ns else at_ns
        if not data:
            return at_ns
        self._tx_wire.append((t, bytes(data)))
        if self.on_line_out is not None:
            k = data.find(10)
            if k >= 0:
                self.on_line_out(t + (k + 1) * self.byte_ns)
        last_start = t + (len(data) - 1) * self.byte_ns
        self._tx_free = t + len(data) * self.byte_ns
        self.tx_bytes += len(data)
        room = last_start - self.tx_ring * self.byte_ns
        return room if room > at_ns else at_ns

    def _deliver(self) -> None:
        wire = self._tx_wire
        if not wire:
            return
        now, step, out = self.clock.now, self.byte_ns, self._host_buf
        while wire:
            t0, data = wire[0]
            pos = self._tx_pos
            end = (now - t0) // step                # bytes of this chunk complete by now
            if end <= pos:
                return
            if end >= len(data):
                out += data[pos:] if pos else data
                wire.popleft()
                self._tx_pos = 0
            else:
                out += data[pos:end]
                self._tx_pos = end
                return

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
        if not self._tx_wire:
            return None
        return self._tx_wire[0][0] + (self._tx_pos + 1) * self.byte_ns

    def tx_line_end(self) -> int | None:
        """When the first line end (LF) still on its way reaches the host, or None when
        none is being sent; now when one has reached it and was not read yet."""
        self._deliver()
        if 10 in self._host_buf:
            return self.clock.now
        pos, step = self._tx_pos, self.byte_ns
        for t0, data in self._tx_wire:
            k = data.find(10, pos)
            if k >= 0:
                return t0 + (k + 1) * step
            pos = 0
        return None

    @property
    def tx_backlog(self) -> int:
        """Bytes the board has sent that have not completely reached the host."""
        self._deliver()
        return sum(len(d) for _, d in self._tx_wire) - self._tx_pos

    @property
    def tx_idle(self) -> bool:
        """Nothing still being sent to the host (bytes delivered but unread do not count)."""
        self._deliver()
        return not self._tx_wire
