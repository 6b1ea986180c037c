"""The host's end of an emulated robot's serial line, shared by every emulated robot
(PAPA-MAN's :class:`~esair_min.emulator.papaman.robot_sim.Emulator`, STARFISH's
:class:`~esair_min.emulator.starfish.robot_sim.StarfishSim`).

A robot using it has a :class:`~esair_min.emulator.clock.VirtualClock` (``clock``), the
central board's :class:`~esair_min.emulator.uart.Uart` at the board file's baud
(``uart``) and says when it is :attr:`idle`. Bytes the host writes reach the board at
line rate and the board's replies come back at line rate (docs/emulator.md, "The
timing model"); nothing here looks at the wall clock.
"""

from __future__ import annotations

from esair_min.emulator.clock import VirtualClock, seconds_to_ns
from esair_min.emulator.uart import Uart


class SerialHost:
    """Writes, reads and whole command exchanges over the robot's emulated line."""

    clock: VirtualClock
    uart: Uart

    @property
    def idle(self) -> bool:
        """No byte on the line either way and nothing left for the board to do with
        what it received."""
        raise NotImplementedError

    def _host_wrote(self, data: bytes) -> None:
        """Called with each write before its bytes go on the line (a robot's record)."""

    def write(self, data: bytes) -> None:
        """The host sends ``data`` now; it reaches the board at line rate."""
        data = bytes(data)
        self._host_wrote(data)
        self.uart.host_write(data)

    def read(self) -> bytes:
        """Every byte the board has completely sent by now (and not read yet)."""
        return self.uart.host_read()

    def next_event_ns(self) -> int | None:
        """When something next happens inside the robot (for real-time pacing)."""
        candidates = [t for t in (self.clock.next_event(), self.uart.tx_next()) if t is not None]
        return min(candidates) if candidates else None

    def _step(self, limit_ns: int) -> None:
        """Run to the next thing that happens (an event or a byte reaching the host),
        never past ``limit_ns``; always makes progress."""
        clock = self.clock
        before = clock.now
        nxt = self.next_event_ns()
        if nxt is None or nxt > limit_ns:
            self.run_until(limit_ns)
        elif clock.run_until(nxt) == 0 and clock.now == before:
            self.run_until(limit_ns)      # cannot happen; guards against a stall

    def _run_to_line(self, limit_ns: int) -> None:
        """Run until the next line end reaches the host (one already on its way, or one
        the board sends meanwhile), never past ``limit_ns``: where stepping byte by byte
        would stop, in one run (so the UART's fast paths work)."""
        clock, uart = self.clock, self.uart
        line_end = uart.tx_line_end()
        if line_end is not None and line_end <= clock.now:
            return                        # a line has reached the host: read it first
        uart.on_line_out = clock.stop_at
        try:
            clock.run_until(limit_ns if line_end is None or line_end > limit_ns else line_end)
        finally:
            uart.on_line_out = None

    def run_until(self, t_ns: int) -> None:
        self.clock.run_until(t_ns)

    def settle(self, max_s: float = 1.0) -> None:
        """Run until :attr:`idle` (every byte answered and delivered), at most ``max_s``."""
        end = self.clock.now + seconds_to_ns(max_s)
        clock = self.clock
        while not self.idle and clock.now < end:
            self._step(end)

    def exchange(self, line: str | bytes, timeout_s: float = 2.0) -> list[str]:
        """Send one line (CR LF added) and run until its reply reached the host.

        Returns every line received meanwhile (notices included), the reply last;
        stops after ``timeout_s`` of virtual time without a reply.
        """
        data = line.encode("latin-1") if isinstance(line, str) else bytes(line)
        end = self.clock.now + seconds_to_ns(timeout_s)
        self._send_line(data, end)
        return self._collect(end)

    def _send_line(self, data: bytes, end_ns: int) -> None:
        """The host sends ``data`` and its CR LF now (a robot may take it to its decoder
        at once where that changes nothing: StarfishSim)."""
        self.write(data + b"\r\n")

    def _collect(self, end_ns: int) -> list[str]:
        """Run until a line that is not a notice has reached the host, at most to
        ``end_ns``: every line received meanwhile, that one last."""
        got = self._take_reply(end_ns)
        return got if got is not None else self._collect_lines(end_ns)

    def _take_reply(self, end_ns: int) -> list[str] | None:
        """The usual reply: one line alone first on the wire, not a notice, nothing
        delivered before it. Runs to its line end, as :meth:`_collect_lines` would (output
        the board sends meanwhile queues behind it, so nothing ends the run sooner), and
        returns it; None (nothing run) for anything else."""
        uart, clock = self.uart, self.clock
        wire = uart._tx_wire
        if not wire or uart._tx_pos or uart._host_buf:
            return None
        t0, data = wire[0]
        k = data.find(10)
        at = t0 + (k + 1) * uart.byte_ns
        if k != len(data) - 1 or not clock.now < at <= end_ns or data[:1] == b"!":
            return None
        clock.run_until(at)
        out = uart.host_read()
        if out != data:                   # (cannot happen) left for _collect_lines
            uart._host_buf[:0] = out
            return None
        return [data[:k].decode("latin-1").rstrip("\r")]

    def _collect_lines(self, end_ns: int) -> list[str]:
        """:meth:`_collect` in general: line by line, stopping at each line end."""
        clock = self.clock
        got: list[str] = []
        buf = bytearray()
        while clock.now < end_ns:
            self._run_to_line(end_ns)
            buf += self.read()
            while b"\n" in buf:
                raw, _, rest = bytes(buf).partition(b"\n")
                buf = bytearray(rest)
                text = raw.decode("latin-1").rstrip("\r")
                got.append(text)
                if not text.startswith("!"):
                    return got
        return got
