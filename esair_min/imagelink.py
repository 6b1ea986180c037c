"""The motion image over the robot's own serial link (docs/protocol.md, "Writing the
motion image"): write it (only the chunks that differ), read it back, verify it.

The requests are pipelined: a line is sent while earlier ones still wait for their
replies, as long as the lines after the oldest unanswered one fit in the board's
64-byte receive ring (the oldest is taken out of the ring by the decoder, which is free
once the reply before it came; only its execution holds the decoder). So no byte is
ever lost to an overrun, and the wire is kept busy both ways: reads of chunks further
on while a page write runs.
"""

from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass
from typing import Any, Callable

from esair_min.components.motion.layout import HEADER_BYTES, MAGIC, VERSION
from esair_min.core import protocol as P
from esair_min.core.image import header_of
from esair_min.errors import EsairError, ProtocolError
from esair_min.model.encoding import CHECKSUM_CHARS, MAX_LINE
from esair_min.model.robot import Robot
from esair_min.serialport import describe

#: Data bytes a chunk carries at most (16 fills a line with a one-letter prefix).
CHUNK_MAX = 16
#: Reads of chunks ahead unanswered while writing (the write of a chunk that differs
#: follows its read's reply).
READ_AHEAD = 2

Progress = Callable[[int, int], None]     # (bytes done, bytes in all)


@dataclass(frozen=True)
class WriteResult:
    chunks: int          # chunks of the image
    written: int         # chunks that differed and were written
    seconds: float       # from the first request to the commit's check
    crc: int             # the robot's image CRC after the commit


class ImageLink:
    """``ser``: an open pySerial port to ``robot``'s central board."""

    def __init__(self, ser: Any, robot: Robot, timeout: float = 3.0):
        self.ser = ser
        self.robot = robot
        self.timeout = timeout
        prefixes = {c.action: c.prefix for c in robot.commands}
        missing = [a for a in ("image_write", "image_read", "image_commit", "version", "stop")
                   if a not in prefixes]
        if missing:
            raise EsairError(f"robot '{robot.name}': its central board's command table has "
                             f"no {', '.join(missing)} command (docs/protocol.md)")
        self.p_write = prefixes["image_write"]
        self.p_read = prefixes["image_read"]
        self.p_commit = prefixes["image_commit"]
        self.p_version = prefixes["version"]
        self.p_stop = prefixes["stop"]
        uart = robot.central.uart
        self.checksum = bool(uart and uart.require_checksum)
        eep = robot.eeprom
        if eep is None:
            raise EsairError(f"robot '{robot.name}' has no EEPROM for motions")
        self.size = eep.size_bytes
        self.page = eep.page_bytes
        room = MAX_LINE - len(self.p_write) - 6 - (CHECKSUM_CHARS if self.checksum else 0)
        self.chunk = min(CHUNK_MAX, room // 2, self.page)
        self._queue: deque[str] = deque()       # lines not sent yet
        self._sent: deque[tuple[str, int]] = deque()   # lines sent, bytes: no reply yet
        self._buf = bytearray()
        self._reads: set[str] = set()           # the read lines of write_image

    # -- the pipe ----------------------------------------------------------------------
    def _frame(self, line: str) -> bytes:
        return P.frame_line(line, self.checksum)

    def _fits(self, n: int) -> bool:
        if not self._sent:
            return True
        behind = sum(k for _, k in list(self._sent)[1:])
        return behind + n <= P.RX_RING

    def _send_ready(self, urgent: deque[str] | None = None) -> None:
        """Send what the window allows: ``urgent`` lines (writes) first; the queue's
        only while no urgent line waits, at most READ_AHEAD of them unanswered (reads
        ahead keep the return wire busy; more would keep writes out of the window)."""
        while urgent:
            data = self._frame(urgent[0])
            if not self._fits(len(data)):
                return
            self._sent.append((urgent.popleft(), len(data)))
            self._io(self.ser.write, data)
        q = self._queue
        while q and (urgent is None or
                     sum(1 for line, _ in self._sent if line in self._reads) < READ_AHEAD):
            data = self._frame(q[0])
            if not self._fits(len(data)):
                return
            self._sent.append((q.popleft(), len(data)))
            self._io(self.ser.write, data)

    def _io(self, fn: Callable[..., Any], *args: Any) -> Any:
        """A call on the port; its failure (a device gone, a robot killed behind its
        pty) as an EsairError."""
        import serial

        try:
            return fn(*args)
        except (serial.SerialException, OSError) as exc:
            raise EsairError(f"the robot's port failed: {describe(exc)}") from None

    def _reply(self) -> str:
        """The next reply line (notices skipped)."""
        deadline = time.monotonic() + self.timeout
        while True:
            got = self._io(self.ser.readline)
            self._buf += got
            if self._buf.endswith(b"\n"):
                text = self._buf.decode("latin-1").strip("\r\n")
                self._buf.clear()
                if text and not text.startswith("!"):
                    return text
                continue
            if time.monotonic() >= deadline:
                line = self._sent[0][0] if self._sent else "?"
                raise EsairError(f"no reply to {line!r} within {self.timeout:g} s: is the "
                                 "robot on this port, at this baud?")

    def _next(self, urgent: deque[str] | None = None) -> tuple[str, str]:
        self._send_ready(urgent)
        reply = self._reply()
        line, _ = self._sent.popleft()
        return line, reply

    def ask(self, line: str) -> str:
        """One request alone (nothing else in flight): its reply."""
        assert not self._sent and not self._queue
        self._queue.append(line)
        return self._next()[1]

    # -- requests ----------------------------------------------------------------------
    def version(self) -> dict[str, str]:
        reply = self.ask(self.p_version)
        if not reply.startswith("OK "):
            raise EsairError(f"the robot answers {reply!r} to {self.p_version!r}")
        return P.version_fields(reply[3:])

    def robot_crc(self) -> int | None:
        """The CRC of the robot's valid image, None if its image is not valid."""
        fields = self.version()
        if fields.get("image") != "ok" or "crc" not in fields:
            return None
        return int(fields["crc"], 16)

    def chunks(self, length: int) -> list[tuple[int, int]]:
        """(address, bytes) of each chunk of ``length`` bytes: none crosses a page."""
        out, at = [], 0
        while at < length:
            n = min(self.chunk, length - at, self.page - at % self.page)
            out.append((at, n))
            at += n
        return out

    def _read_line(self, at: int, n: int) -> str:
        return P.encode_image_read(at, n, self.p_read)

    def _parse_read(self, at: int, reply: str) -> bytes:
        if not reply.startswith("OK "):
            raise EsairError(f"reading the EEPROM at 0x{at:04X}: the robot answers {reply!r}")
        try:
            return P.decode_image_read(at, reply[3:])
        except ProtocolError as exc:
            raise EsairError(f"reading the EEPROM at 0x{at:04X}: {exc}") from None

    def stop(self) -> None:
        """Stop a playing motion: the image verbs are refused (E07) while one plays."""
        reply = self.ask(self.p_stop)
        if reply != "OK":
            raise EsairError(f"the robot answers {reply!r} to {self.p_stop!r}")

    def read(self, at: int, length: int, progress: Progress | None = None) -> bytes:
        """``length`` bytes of the EEPROM from ``at`` (pipelined reads; a playing
        motion is stopped first)."""
        self.stop()
        parts = [(a, min(P.READ_MAX, at + length - a)) for a in range(at, at + length,
                                                                      P.READ_MAX)]
        for a, n in parts:
            self._queue.append(self._read_line(a, n))
        out = bytearray()
        for a, _ in parts:
            _, reply = self._next()
            out += self._parse_read(a, reply)
            if progress:
                progress(len(out), length)
        return bytes(out)

    def read_image(self, progress: Progress | None = None) -> bytes:
        """The image on the EEPROM: its header, then the bytes its length covers."""
        header = self.read(0, HEADER_BYTES)
        h = header_of(header)
        if h.magic[1:] != MAGIC[1:] or h.magic[0] not in (MAGIC[0], 0xFF) or h.version != VERSION:
            raise EsairError(f"the EEPROM holds no motion image (its first bytes are "
                             f"{header.hex(' ')})")
        if not HEADER_BYTES <= h.length <= self.size:
            raise EsairError(f"the EEPROM's image header gives length {h.length}, outside "
                             f"{HEADER_BYTES}..{self.size}")
        return header + self.read(HEADER_BYTES, h.length - HEADER_BYTES, progress)

    def write_image(self, image: bytes, progress: Progress | None = None) -> WriteResult:
        """Read each chunk, write the ones that differ (the header's always first: it
        opens the write), commit, check the robot's CRC. A robot already holding
        ``image`` (its CRC, valid) gets nothing written."""
        start = time.monotonic()
        want = int.from_bytes(image[6:8], "little")
        chunks = self.chunks(len(image))
        if self.robot_crc() == want:
            if progress:
                progress(len(image), len(image))
            return WriteResult(len(chunks), 0, time.monotonic() - start, want)
        self.stop()
        for at, n in chunks:
            self._queue.append(self._read_line(at, n))
        self._reads = set(self._queue)
        writes: deque[str] = deque()
        pending = deque(chunks)            # reads whose replies are due, in order
        written = done = 0
        while pending or self._sent:
            line, reply = self._next(writes)
            if pending and line == self._read_line(*pending[0]):
                at, n = pending.popleft()
                try:
                    have: bytes | None = self._parse_read(at, reply)
                except EsairError:      # a reply damaged on the line: the chunk is written
                    have = None         # (the commit's CRC check judges the whole image)
                new = image[at:at + n]
                if at == 0 or have != new:
                    data = bytearray(new)
                    writes.append(P.encode_image_write(at, data, self.p_write))
                else:
                    done += n
                    if progress:
                        progress(done, len(image))
                continue
            if reply != "OK":
                raise EsairError(f"writing the EEPROM: the robot answers {reply!r} to "
                                 f"{line!r}")
            written += 1
            at = int(line[len(self.p_write):len(self.p_write) + 4], 16)
            done += next(n for a, n in chunks if a == at)
            if progress:
                progress(done, len(image))
        reply = self.ask(self.p_commit)
        if reply != "OK":
            raise EsairError(f"the robot refused the image at its commit: {reply!r} (its "
                             "check of the written bytes failed)")
        crc = self.robot_crc()
        if crc != want:
            raise EsairError(f"after the commit the robot reports image CRC {crc!r}, not "
                             f"0x{want:04X}")
        return WriteResult(len(chunks), written, time.monotonic() - start, want)

    def verify(self, image: bytes, progress: Progress | None = None) -> list[int]:
        """The addresses of the chunks that differ from ``image`` (header included; a
        valid robot image reports its CRC as well: see :meth:`robot_crc`)."""
        have = self.read(0, len(image), progress)
        return [at for at, n in self.chunks(len(image)) if have[at:at + n] != image[at:at + n]]
