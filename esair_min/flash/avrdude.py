"""Flashing an ATmega328P board through avrdude: its Arduino bootloader over the board's
USB-serial (``-c arduino``: Optiboot at 115200 baud on an Uno or a new Nano, ATmegaBOOT
at 57600 on an old Nano), or any avrdude programmer for a bare chip (then also the fuses
the board file's clock needs). avrdude writes, then reads back and verifies; its output
is turned into progress and, on failure, into one :class:`FlashError` naming the likely
cause (docs/hardware.md).
"""

from __future__ import annotations

import re
import shutil
import subprocess
import os
import select
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

from esair_min.flash import FlashError

#: a flash's progress: (phase "writing" | "verifying", percent 0..100)
Progress = Callable[[str, int], None]

#: bootloader -> its baud rate at 16 MHz (what -c arduino must use)
BOOTLOADER_BAUD = {"optiboot": 115200, "atmegaboot": 57600}
BOOTLOADER_BOARDS = {"optiboot": "Uno, Nano with the new bootloader, Optiboot",
                     "atmegaboot": "old Nano (ATmegaBOOT)"}
#: device signatures avrdude may read, by the name a builder knows
SIGNATURES = {"1e950f": "ATmega328P", "1e9514": "ATmega328", "1e9406": "ATmega168",
              "1e940b": "ATmega168P", "1e9307": "ATmega8", "1e9587": "ATmega32U4",
              "1e9801": "ATmega2560", "1e930a": "ATmega88"}
AVRDUDE_PART = {"atmega328p": ("m328p", "ATmega328P", "1e950f")}


@dataclass(frozen=True)
class Fuses:
    """An ATmega328P's three fuse bytes (0 bits are programmed)."""

    low: int
    high: int
    extended: int

    def describe(self) -> str:
        return f"lfuse 0x{self.low:02X} hfuse 0x{self.high:02X} efuse 0x{self.extended:02X}"

    def args(self) -> list[str]:
        return [f"-U{name}:w:0x{value:02X}:m" for name, value in
                (("lfuse", self.low), ("hfuse", self.high), ("efuse", self.extended))]


def fuses_for(clock_hz: int) -> tuple[Fuses, str]:
    """The fuses of a bare ATmega328P running the board file's clock from a crystal, with
    no bootloader (the chip starts at 0; SPI programming kept on; brown-out at 2.7 V),
    and why. Low fuse: CKDIV8 off, slowest start-up, CKSEL for the crystal's range."""
    if clock_hz > 16_000_000:
        low, why = 0xF7, "full-swing crystal oscillator (above 16 MHz)"
    elif clock_hz >= 8_000_000:
        low, why = 0xFF, "low-power crystal oscillator, 8-16 MHz"
    elif clock_hz >= 3_000_000:
        low, why = 0xFD, "low-power crystal oscillator, 3-8 MHz"
    else:
        low, why = 0xFB, "low-power crystal oscillator, 0.9-3 MHz"
    return Fuses(low, 0xD9, 0xFD), (f"{clock_hz / 1e6:g} MHz crystal: {why}; no boot "
                                    "section (BOOTRST off), SPIEN on; BOD 2.7 V")


@dataclass(frozen=True)
class AvrFlash:
    """One avrdude run: write ``hex_path`` (and the fuses, if given) and verify."""

    hex_path: Path
    port: str
    part: str = "atmega328p"
    programmer: str = "arduino"
    bootloader: str = "optiboot"
    baud: int | None = None
    attempts: int = 3
    fuses: Fuses | None = None
    verify_only: bool = False      # compare the chip's flash with the .hex, write nothing

    @property
    def through_bootloader(self) -> bool:
        return self.programmer == "arduino"

    @property
    def line_baud(self) -> int | None:
        if self.baud is not None or not self.through_bootloader:
            return self.baud
        return BOOTLOADER_BAUD[self.bootloader]

    def command(self, avrdude: str = "avrdude") -> list[str]:
        part = AVRDUDE_PART[self.part][0]
        cmd = [avrdude, "-p", part, "-c", self.programmer, "-P", self.port]
        if self.line_baud is not None:
            cmd += ["-b", str(self.line_baud)]
        if self.through_bootloader:
            # the bootloader cannot erase the whole chip (it would erase itself): pages are
            # erased as they are written
            cmd += ["-x", f"attempts={self.attempts}", "-D"]
        cmd += [f"-Uflash:{'v' if self.verify_only else 'w'}:{self.hex_path}:i"]
        if self.fuses is not None and not self.verify_only:
            cmd += self.fuses.args()
        return cmd


def avrdude_path() -> str:
    path = shutil.which("avrdude")
    if path is None:
        raise FlashError("avrdude is not installed; run scripts/install-toolchain.sh (as root) "
                         "or apt-get install avrdude")
    return path


class _Output:
    """avrdude's output read as it comes: its progress bars ("Writing |" or "Reading |",
    then 50 '#') reported every 10 %, and its text."""

    def __init__(self, progress: Progress | None) -> None:
        self.progress = progress
        self.text: list[str] = []
        self.phases: list[str] = []
        self.steps: list[int] = []

    def feed(self, chunk: str) -> None:
        self.text.append(chunk)
        parts = re.split(r"(Writing \||Reading \|)", self.all)
        for i in range(1, len(parts), 2):
            n = i // 2
            if n == len(self.phases):
                self.phases.append("writing" if parts[i][0] == "W" else "verifying")
                self.steps.append(-1)
            step = parts[i + 1].split("|", 1)[0].count("#") // 5
            for s in range(self.steps[n] + 1, step + 1):
                if self.progress is not None:
                    self.progress(self.phases[n], 10 * s)
            self.steps[n] = max(self.steps[n], step)

    @property
    def all(self) -> str:
        return "".join(self.text)


def flash_avr(plan: AvrFlash, progress: Progress | None = None, timeout: float = 600.0,
              avrdude: str | None = None, watch_fd: int | None = None) -> str:
    """Run avrdude for ``plan``; return its output. Raises FlashError (the likely cause)
    when it fails: no bootloader answering, another chip, a failed verify, the line lost
    during the write. ``watch_fd``: an open descriptor of the port (the lock's): when it
    hangs up (a USB adapter unplugged, a pty's other end gone) avrdude is stopped, since
    it would wait on a hung-up port for ever (its reads return 0 bytes, never an error)."""
    cmd = plan.command(avrdude or avrdude_path())
    try:
        proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT)
    except OSError as exc:
        raise FlashError(f"cannot run avrdude: {exc}") from None
    out = _Output(progress)
    assert proc.stdout is not None
    poller = select.poll()
    poller.register(proc.stdout.fileno(), select.POLLIN)
    if watch_fd is not None:
        poller.register(watch_fd, 0)
    deadline = time.monotonic() + timeout
    hung_up = timed_out = False
    try:
        while True:
            events = dict(poller.poll(500))
            if watch_fd is not None and events.get(watch_fd, 0) & (select.POLLHUP | select.POLLERR):
                hung_up = True
                break
            if time.monotonic() > deadline:
                timed_out = True
                break
            if proc.stdout.fileno() in events:
                chunk = os.read(proc.stdout.fileno(), 4096)
                if not chunk:
                    break
                out.feed(chunk.decode("latin-1"))
    finally:
        if hung_up or timed_out:
            proc.kill()
        status = proc.wait()
        proc.stdout.close()
    if hung_up:
        raise FlashError(explain(out.all + "\nesair: the port hung up", plan, out.phases))
    if timed_out:
        raise FlashError(f"avrdude did not finish within {timeout:g} s on {plan.port}")
    if status != 0:
        raise FlashError(explain(out.all, plan, out.phases))
    return out.all


def holds_image(plan: AvrFlash, progress: Progress | None = None,
                watch_fd: int | None = None) -> bool:
    """Whether the chip's flash already holds ``plan``'s .hex (avrdude reads it back
    through the bootloader and compares; nothing is written). FlashError when the board
    cannot be read (the same causes as a flash)."""
    from dataclasses import replace

    try:
        flash_avr(replace(plan, verify_only=True), progress, watch_fd=watch_fd)
    except FlashError as exc:
        if str(exc).startswith("verify failed"):
            return False
        raise
    return True


def explain(text: str, plan: AvrFlash, phases: Sequence[str] = ()) -> str:
    """What failed, in a builder's words, from avrdude's output."""
    port, name = plan.port, AVRDUDE_PART[plan.part][1]
    sig = re.search(r"signature = 0x([0-9a-fA-F]{6})", text)
    if sig and "expected signature" in text.lower():
        got = sig.group(1).lower()
        chip = SIGNATURES.get(got, "an unknown part")
        return (f"the chip on {port} is {chip} (signature {got.upper()}), not the "
                f"{name} the board file names ({AVRDUDE_PART[plan.part][2].upper()}): another "
                "board is on this port, or --board names the wrong board; nothing was written")
    mismatch = re.search(r"!= input 0x[0-9a-fA-F]+ at addr (0x[0-9a-fA-F]+)", text)
    if mismatch or re.search(r"verification (error|mismatch)|content mismatch", text):
        where = f" (first at address {mismatch.group(1)})" if mismatch else ""
        return (f"verify failed{where}: the flash of the board on {port} does not hold what "
                "was sent, so bytes were damaged on the line (a poor USB cable or hub, noise "
                "on a long serial cable); flash again, and if it persists use another cable. "
                "The bootloader itself is untouched")
    if "esair: the port hung up" in text and not phases:
        return (f"{plan.port} went away before anything was written (cable pulled, board "
                "reset or powered off); plug it in and flash again")
    if "writing" in phases or "verifying" in phases:
        what = "write" if phases[-1] == "writing" else "verify"
        return (f"the board on {port} stopped answering during the {what} (cable pulled, "
                "board reset or powered off): its application is incomplete and will not "
                "run, the bootloader is untouched; plug it in and flash again")
    if re.search(r"can't open device|cannot open port|No such file", text, re.I):
        return f"cannot open {port}: no such device (is the board plugged in? ls /dev/ttyUSB* /dev/ttyACM*)"
    if re.search(r"not in sync|not responding|unable to open programmer", text):
        if plan.through_bootloader:
            other = next(b for b in BOOTLOADER_BAUD if b != plan.bootloader)
            return (f"no bootloader answered on {port} at {plan.line_baud} baud: the wrong "
                    "port, the board not powered, or a bootloader at another speed (an "
                    f"{BOOTLOADER_BOARDS[other]} answers at {BOOTLOADER_BAUD[other]}: try "
                    f"--bootloader {other}), or a chip with no bootloader (program it with "
                    "--programmer and an ISP programmer)")
        return (f"the {plan.programmer} programmer on {port} did not answer: check its "
                "cable to the board, the board's power, and the programmer's name")
    lines = [ln for ln in text.splitlines() if "error" in ln.lower() and "TIOCM" not in ln]
    return "avrdude failed: " + ("; ".join(lines[-3:]) or text.strip()[-300:])
