"""Flashing a PIC18F452 board through ESAIR's serial bootloader (docs/bootloader.md).

The image is ``firmware-app.hex`` from ``esair build``: the application linked above the
bootloader, with its record (sum, board tag) in the last row. Everything is checked
before the port is opened; then: hello (device id, version, board tag), every row
0x0200..end written (the bootloader erases the record at the first), the data EEPROM,
everything read back and compared, the record row last, and ``G`` starts the
application. A flash cut anywhere before the record leaves a chip that boots into its
bootloader. Every failure is one :class:`FlashError` naming the cause.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from esair_min.flash import FlashError
from esair_min.model import picboot as B

#: a flash's progress: (phase "writing" | "verifying", percent 0..100)
Progress = Callable[[str, int], None]

DATA = 64                       # every frame carries 64 data bytes
EE_BASE = 0xF00000              # data EEPROM in a hex file (and in the protocol)
CONFIG = range(0x300000, 0x30000E)
IDLOCS = range(0x200000, 0x200008)
REPLY_S = 1.0                   # a row's erase and write take ~18 ms; EEPROM 64 x 4 ms
RETRIES = 3                     # a frame damaged on the line is sent again this often
REPAIRS = 2                     # a row that does not read back is written again this often
ERRORS = {ord("S"): "the bootloader saw a damaged frame (checksum)",
          ord("A"): "the bootloader refused the address",
          ord("?"): "the bootloader did not know the command"}


@dataclass(frozen=True)
class PicImage:
    rows: dict[int, bytes]       # row address -> 64 bytes, 0x0200..end, gaps 0xFF
    eeprom: dict[int, bytes]     # 64-byte block -> bytes (gaps 0xFF)
    record: bytes                # the row at 0x7FC0, written last
    end: int
    tag: int

    @property
    def flash_bytes(self) -> int:
        return len(self.rows) * B.ROW


def frame(cmd: str, address: int = 0, data: bytes = b"") -> bytes:
    """One frame: command, 24-bit address, for W 64 data bytes (zero-padded), checksum."""
    body = bytes([ord(cmd), address >> 16 & 0xFF, address >> 8 & 0xFF, address & 0xFF])
    if cmd == "W":
        body += data.ljust(DATA, b"\0")
    return body + bytes([-sum(body) & 0xFF])


def load_image(hex_path: Path) -> PicImage:
    """The rows to write, from an Intel hex built for the bootloader; FlashError if it is
    not one (unreadable, for another chip, overlapping the bootloader, no record)."""
    from intelhex import IntelHex, IntelHexError

    try:
        ih = IntelHex(str(hex_path))
    except (OSError, IntelHexError) as exc:
        raise FlashError(f"cannot read {hex_path}: {exc}") from None
    addresses = list(ih.addresses())
    low = [a for a in addresses if a < B.BOOT_END]
    if low:
        raise FlashError(f"{hex_path}: {len(low)} bytes at 0x{min(low):04X}..0x{max(low):04X} "
                         f"overlap the bootloader (0x0000..0x{B.BOOT_END - 1:04X}); write the "
                         "application built for it, firmware-app.hex (esair build)")
    alien = [a for a in addresses if a >= B.FLASH_END and a not in CONFIG and a not in IDLOCS
             and not EE_BASE <= a < EE_BASE + B.EEPROM_BYTES]
    if alien:
        raise FlashError(f"{hex_path}: data at 0x{min(alien):06X}, outside the PIC18F452 "
                         "(32 KB flash, 256 B EEPROM): a hex for another chip?")
    flash = bytearray(b"\xff" * B.FLASH_END)
    for a in addresses:
        if a < B.FLASH_END:
            flash[a] = ih[a]
    rec = bytes(flash[B.RECORD:B.FLASH_END])
    if rec[0] != ord("E") or rec[7] != B.VERSION:
        raise FlashError(f"{hex_path}: no ESAIR record at 0x{B.RECORD:04X}: not an "
                         "application built for ESAIR's PIC bootloader (write "
                         "firmware-app.hex from esair build)")
    end = rec[1] << 8 | rec[2]
    app = [a for a in addresses if B.APP_START <= a < B.RECORD]
    if not app or end != B.app_end(app) or rec[3] << 8 | rec[4] != B.app_sum(flash, end):
        raise FlashError(f"{hex_path}: its record does not match its contents (a damaged "
                         "or edited file): build it again")
    rows = {a: bytes(flash[a:a + B.ROW]) for a in range(B.APP_START, end, B.ROW)}
    eeprom: dict[int, bytes] = {}
    for a in addresses:
        if a >= EE_BASE and a < EE_BASE + B.EEPROM_BYTES:
            block = (a - EE_BASE) // DATA * DATA
            old = bytearray(eeprom.get(block, b"\xff" * DATA))
            old[a - EE_BASE - block] = ih[a]
            eeprom[block] = bytes(old)
    return PicImage(rows, eeprom, rec, end, rec[5] << 8 | rec[6])


class Bootloader:
    """The protocol over an open serial port (pySerial's read/write/reset_input_buffer)."""

    def __init__(self, port: Any, name: str, reply_s: float = REPLY_S) -> None:
        self.port = port
        self.name = name
        # how long a reply may take: a real line's host and adapter add their delays;
        # a simulated line with a host that answers at once needs only the chip's
        self.reply_s = reply_s
        # a simulated line (esair_min.pic.gpsim_line) keeps its own time
        self.clock: Callable[[], float] = getattr(port, "clock", time.monotonic)
        self.sleep: Callable[[float], None] = getattr(port, "sleep", time.sleep)

    def _read(self, n: int, timeout: float) -> bytes:
        data = b""
        deadline = self.clock() + timeout
        while len(data) < n:
            left = deadline - self.clock()
            if left <= 0:
                break
            self.port.timeout = left
            data += self.port.read(n - len(data))
        return data

    def exchange(self, cmd: str, address: int = 0, data: bytes = b"", reply: int = 0,
                 timeout: float | None = None, retries: int = RETRIES) -> bytes:
        """Send a frame; its reply's data (``reply`` bytes after 'K'), waited for
        ``timeout`` s (``reply_s`` by default). A damaged or missing reply, or the
        bootloader seeing a damaged frame, sends it again."""
        timeout = self.reply_s if timeout is None else timeout
        why = "no answer"
        for _ in range(retries):
            self.port.reset_input_buffer()
            self.port.write(frame(cmd, address, data))
            got = self._read(1, timeout)
            if not got and retries > 1:
                # late rather than lost (a loaded line or simulator): a frame sent again
                # now would take this one's late answer as its own
                got = self._read(1, timeout)
            if got and got[0] == ord("K"):
                rest = self._read(reply + 1, timeout)
                if len(rest) == reply + 1 and (sum(got + rest) & 0xFF) == 0:
                    return rest[:reply]
                why = f"a damaged answer ({len(rest)} of {reply + 1} bytes after K)"
            elif got and got[0] in ERRORS:
                rest = self._read(1, timeout)
                if got[0] == ord("A"):
                    raise FlashError(f"{ERRORS[got[0]]} 0x{address:06X} (command {cmd})")
                why = ERRORS[got[0]]
            elif got:
                why = f"an unexpected byte 0x{got[0]:02X}"
            self.sleep(B.GAP_MS * 2 / 1000)       # the bootloader drops a cut frame
        raise FlashError(f"{self.name}: {why} to {cmd} at 0x{address:06X} after {retries} "
                         "tries: the line drops or damages bytes (cable, baud rate, another "
                         "program on the port?)")

    def hello(self, wait: float) -> tuple[int, int, int]:
        """(device id, version, board tag), saying hello until ``wait`` seconds pass."""
        deadline = self.clock() + wait
        while True:
            try:
                got = self.exchange("H", reply=5, timeout=0.15, retries=1)
                return got[1] << 8 | got[0], got[2], got[3] << 8 | got[4]
            except FlashError:
                if self.clock() >= deadline:
                    raise FlashError(
                        f"no bootloader answered on {self.name} in {wait:g} s: reset the "
                        f"board (its bootloader listens {B.WINDOW_MS} ms after a reset, or "
                        "always when it has no valid application), check the cable and "
                        f"that the line runs at the bootloader's {B.BOOT_BAUD} baud") from None


def check_hello(image: PicImage, device: int, version: int, tag: int, name: str) -> None:
    # gpsim's PIC18F452 has no device id (reads 0); no real PIC18 reads 0 there
    if device != 0 and device & B.DEVICE_ID_MASK != B.DEVICE_ID:
        raise FlashError(f"{name}: the chip's device id is 0x{device:04X}, not a PIC18F452 "
                         f"(0x{B.DEVICE_ID:04X})")
    if version != B.VERSION:
        raise FlashError(f"{name}: bootloader version {version}, this ESAIR speaks "
                         f"{B.VERSION}: put the bootloader of this version on the chip")
    if tag != image.tag:
        raise FlashError(f"{name}: the chip's bootloader was built for another board (tag "
                         f"0x{tag:04X}, the file's 0x{image.tag:04X}): check --board and the "
                         "port")


def flash_pic(hex_path: Path, port: str, *, baud: int, progress: Progress | None = None,
              connect_timeout: float = 10.0) -> None:
    """Write ``hex_path`` (firmware-app.hex) through the bootloader on ``port``, verify it
    and start it. FlashError names what went wrong; the chip then boots into its
    bootloader (the record is written last)."""
    import serial

    from esair_min.serialport import describe, open_port

    image = load_image(Path(hex_path))
    try:
        # not locked again: esair flash holds the port's lock (esair_min/flash/portlock.py)
        ser = open_port(port, baudrate=baud, timeout=0.1, exclusive=False)
    except (serial.SerialException, OSError, ValueError) as exc:
        raise FlashError(f"cannot open {port}: {describe(exc)}") from None
    try:
        _flash(Bootloader(ser, port), image, progress or (lambda _phase, _pct: None),
               connect_timeout)
    finally:
        ser.close()


def write_image(boot: Bootloader, image: PicImage, progress: Progress | None = None,
                wait: float = 10.0) -> None:
    """The whole flash over ``boot``: hello and its checks, write, verify, the record,
    start the application."""
    _flash(boot, image, progress or (lambda _phase, _pct: None), wait)


def _flash(boot: Bootloader, image: PicImage, progress: Progress, wait: float) -> None:
    check_hello(image, *boot.hello(wait), boot.name)
    writes = [(a, d) for a, d in image.rows.items()] + \
        [(EE_BASE + a, d) for a, d in sorted(image.eeprom.items())]
    progress("writing", 0)
    for i, (address, data) in enumerate(writes):
        boot.exchange("W", address, data)
        progress("writing", 100 * (i + 1) // len(writes))
    progress("verifying", 0)
    for i, (address, data) in enumerate(writes):
        got = boot.exchange("R", address, reply=DATA)
        for _ in range(REPAIRS):           # a row that does not read back: written again
            if got == data:
                break
            boot.exchange("W", address, data)
            got = boot.exchange("R", address, reply=DATA)
        if got != data:
            at = next(j for j in range(DATA) if got[j] != data[j])
            raise FlashError(f"{boot.name}: verify failed at 0x{address + at:06X}: wrote "
                             f"0x{data[at]:02X}, read 0x{got[at]:02X}; the application is "
                             "not started (the chip stays in its bootloader)")
        progress("verifying", 100 * (i + 1) // len(writes))
    boot.exchange("W", B.RECORD, image.record)
    if boot.exchange("R", B.RECORD, reply=DATA) != image.record:
        raise FlashError(f"{boot.name}: the record did not read back; the chip stays in its "
                         "bootloader")
    boot.exchange("G")
