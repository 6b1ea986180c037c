"""A simulated Arduino Uno/Nano for flashing tests: simavr runs a chip whose flash holds a
real bootloader (Debian's ``arduino-core-avr``: Optiboot, or the old Nano's ATmegaBOOT),
in real time, with its USART0 on a pseudo-terminal (``simuno.c``), so the real avrdude
writes and verifies through it. The chip's flash is a file: what was written survives the
simulator being killed, as a real chip's does when its cable is pulled.
"""

from __future__ import annotations

import hashlib
import os
import signal
import subprocess
import tempfile
import threading
from dataclasses import dataclass
from pathlib import Path

from esair_min.avr.simavr_harness import SimError, simulator

SOURCE = Path(__file__).with_name("simuno.c")
BOOTLOADERS = Path("/usr/share/arduino/hardware/arduino/avr/bootloaders")
#: bootloader name -> (the part, the boot section's start, how it is made): the old Nano's
#: ATmegaBOOT is Debian's .hex as shipped; Optiboot is built from Debian's optiboot.c
#: (see :func:`optiboot`)
IMAGES = {"optiboot": ("atmega328p", 0x7E00, "source"),
          "atmegaboot": ("atmega328p", 0x7800, "atmega/ATmegaBOOT_168_atmega328.hex"),
          "optiboot168": ("atmega168", 0x3E00, "source")}
FLASH_BYTES = {"atmega328p": 32768, "atmega168": 16384}
#: the flags of the Makefile arduino-core-avr ships beside optiboot.c
OPTIBOOT_FLAGS = ("-Os", "-fno-inline-small-functions", "-fno-split-wide-types",
                  "-mshort-calls", "-DF_CPU=16000000L", "-DBAUD_RATE=115200",
                  "-DLED_START_FLASHES=0", "-Wl,--relax", "-Wl,--gc-sections",
                  "-nostartfiles", "-nostdlib")


def _shipped(rel: str) -> Path:
    path = BOOTLOADERS / rel
    if not path.exists():
        raise SimError(f"{path} is missing (Debian's arduino-core-avr); run "
                       "scripts/install-toolchain.sh (as root) to install it")
    return path


def optiboot(part: str = "atmega328p", cache: Path | None = None) -> Path:
    """Optiboot 4.4 for ``part``, built (cached) from the optiboot.c that Debian's
    arduino-core-avr ships, with its Makefile's flags but no LED flashes at reset: the
    shipped optiboot_atmega328.hex, built by Debian's avr-gcc 5.4 with 3 LED flashes, is
    530 + 2 bytes and does not fit the 512-byte boot section (its version word at 0x7FFE
    overwrites an instruction, its last 20 bytes lie past the end of flash: see
    docs/hardware.md); without the flashes it is 496 + 2."""
    src = _shipped("optiboot/optiboot.c")
    boot = IMAGES["optiboot168" if part == "atmega168" else "optiboot"][1]
    digest = hashlib.sha256(src.read_bytes() + repr(OPTIBOOT_FLAGS).encode()).hexdigest()[:12]
    base = cache or Path(tempfile.gettempdir()) / "esair-avr-driver"
    out = base / f"optiboot-{part}-{digest}.hex"
    if out.exists():
        return out
    base.mkdir(parents=True, exist_ok=True)
    elf = out.with_suffix(f".{os.getpid()}.elf")
    tmp = out.with_suffix(f".{os.getpid()}.tmp")
    try:
        subprocess.run(["avr-gcc", f"-mmcu={part}", *OPTIBOOT_FLAGS, f"-I{src.parent}",
                        f"-Wl,--section-start=.text=0x{boot:x}",
                        f"-Wl,--section-start=.version=0x{FLASH_BYTES[part] - 2:x}",
                        "-o", str(elf), str(src)], capture_output=True, text=True,
                       timeout=120, check=True)
        subprocess.run(["avr-objcopy", "-j", ".text", "-j", ".data", "-j", ".version",
                        "--set-section-flags", ".version=alloc,load", "-O", "ihex",
                        str(elf), str(tmp)], capture_output=True, text=True, timeout=60,
                       check=True)
    except (OSError, subprocess.SubprocessError) as exc:
        detail = getattr(exc, "stderr", "") or exc
        raise SimError(f"cannot build Optiboot from {src}: {detail}") from None
    finally:
        elf.unlink(missing_ok=True)
    tmp.replace(out)
    return out


def bootloader_hex(name: str) -> Path:
    """The Intel HEX of a bootloader by name (see IMAGES)."""
    part, _, how = IMAGES[name]
    return optiboot(part) if how == "source" else _shipped(how)


def read_flash_hex(path: Path, size: int) -> dict[int, int]:
    """The bytes an Intel HEX file puts in a flash of ``size`` bytes, by address (a later
    record wins: Debian's optiboot_atmega328.hex gives its version word twice)."""
    out: dict[int, int] = {}
    base = 0
    for n, line in enumerate(path.read_text(encoding="latin-1").splitlines(), 1):
        line = line.strip()
        if not line.startswith(":"):
            continue
        rec = bytes.fromhex(line[1:])
        if len(rec) < 5 or len(rec) != rec[0] + 5 or sum(rec) & 0xFF:
            raise SimError(f"{path}:{n}: not a valid Intel HEX record")
        kind, addr, payload = rec[3], (rec[1] << 8) | rec[2], rec[4:-1]
        if kind == 0:
            out.update({base + addr + i: b for i, b in enumerate(payload)})
        elif kind in (2, 4):
            base = int.from_bytes(payload, "big") << (4 if kind == 2 else 16)
    if out and max(out) >= size:
        raise SimError(f"{path}: data at 0x{max(out):X}, beyond the {size}-byte flash")
    return out


def new_chip(flash: Path, bootloader: str | None = "optiboot",
             app: Path | None = None) -> int:
    """Write a chip's flash file: erased (0xFF), with a bootloader and/or an application
    image; returns where a reset starts (the bootloader's first byte, or 0)."""
    part = IMAGES[bootloader][0] if bootloader else "atmega328p"
    data = bytearray(b"\xff" * FLASH_BYTES[part])
    boot = 0
    for image in ([bootloader_hex(bootloader)] if bootloader else []) + ([app] if app else []):
        cells = read_flash_hex(image, len(data))
        for a, v in cells.items():
            data[a] = v
        if image != app:
            boot = min(cells)
    flash.write_bytes(bytes(data))
    return boot


@dataclass
class SimUno:
    """One simulated board (``with SimUno(...) as uno``): ``uno.port`` is the stable path
    avrdude and ESAIR open (a symlink to the pty), ``uno.events`` what the simulator said
    (``page``, ``reset``, ``damaged`` lines), ``uno.kill()`` pulls the cable."""

    flash: Path
    port: Path
    boot: int
    part: str = "atmega328p"
    clock_hz: int = 16_000_000
    damage_at: int = 0
    eeprom: Path | None = None       # a 24LC256 at 0x50: its 32 KB in this file

    def __post_init__(self) -> None:
        self.events: list[str] = []
        self._cond = threading.Condition()
        self._proc: subprocess.Popen[str] | None = None

    def __enter__(self) -> SimUno:
        exe = simulator(source=SOURCE)
        args = [str(exe), self.part, str(self.flash), str(self.boot), str(self.clock_hz),
                str(self.port)]
        if self.damage_at or self.eeprom is not None:
            args.append(str(self.damage_at))
        if self.eeprom is not None:
            if not self.eeprom.exists():
                self.eeprom.write_bytes(b"\xff" * 32768)       # a new, blank 24LC256
            args.append(str(self.eeprom))
        self._proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                      text=True, stdin=subprocess.DEVNULL)
        threading.Thread(target=self._read, daemon=True).start()
        if not self.wait_for("ready", 30):
            self.kill()
            raise SimError(f"the simulated board did not start: {self._stderr()}")
        return self

    def _read(self) -> None:
        assert self._proc is not None and self._proc.stdout is not None
        for line in self._proc.stdout:
            with self._cond:
                self.events.append(line.strip())
                self._cond.notify_all()
        with self._cond:
            self.events.append("exit")
            self._cond.notify_all()

    def _stderr(self) -> str:
        if self._proc is None or self._proc.stderr is None or self._proc.poll() is None:
            return ""
        return self._proc.stderr.read().strip()

    def wait_for(self, word: str, timeout: float, after: int = 0,
                 test=lambda fields: True) -> str | None:
        """The first event from index ``after`` whose first field is ``word`` (and that
        passes ``test``), waiting up to ``timeout`` s; None when it does not come."""
        def found() -> str | None:
            return next((e for e in self.events[after:] if e.split()[0] == word
                         and test(e.split())), None)
        with self._cond:
            self._cond.wait_for(lambda: found() is not None or "exit" in self.events, timeout)
            return found()

    def kill(self) -> None:
        """SIGKILL the simulator (a cable pulled, the power cut): its pty goes away."""
        if self._proc is not None and self._proc.poll() is None:
            os.kill(self._proc.pid, signal.SIGKILL)
            self._proc.wait()

    def __exit__(self, *exc: object) -> None:
        self.kill()
        if self._proc is not None:
            for stream in (self._proc.stdout, self._proc.stderr):
                if stream is not None:
                    stream.close()
        self.port.unlink(missing_ok=True)

    def flash_bytes(self) -> bytes:
        """The chip's flash as it is now."""
        return self.flash.read_bytes()
