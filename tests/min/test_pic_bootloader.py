"""ESAIR's PIC18F452 serial bootloader (docs/bootloader.md), run in gpsim: gpsim's
self-programming, the boot block and the relocated application, a whole PAPA-MAN
central written, read back and answering ``v``, flashes cut at several points, and the
faults of issue 33 (another chip, another board, overlapping the bootloader, a line
that drops or damages bytes, nobody answering). Needs the toolchain."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest
from intelhex import IntelHex

from esair_min.flash import FlashError
from esair_min.flash.pic import (EE_BASE, Bootloader, check_hello, flash_pic, frame,
                                 load_image, write_image)
from esair_min.model import picboot
from esair_min.pic.bootbuild import add_record, program_bytes
from esair_min.pic.build import summary_lines
from esair_min.pic.gpsim_i2c import GpsimSession
from esair_min.pic.gpsim_line import LineFault, SimLine
from esair_min.pic.toolchain import run_gpsim
from tests.support.robot_ptys import open_pty

pytestmark = [pytest.mark.gpsim, pytest.mark.pty]

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "pic"
CLOCK = 20_000_000
#: a reply's longest wait in simulated time, the host answering at once: a data EEPROM
#: block (64 x 4 ms) and its frame take 0.26 s (a real line's 1 s would only lengthen
#: each cut's three unanswered tries)
REPLY_S = 0.5
#: the bootloader's exact size (gpasm); the boot block holds 512
BOOT_BYTES = 512


@pytest.fixture(scope="module")
def central(papaman_boot):
    """PAPA-MAN's central alone, built as esair build does (the bootloader included;
    tests/conftest.py)."""
    return papaman_boot


@pytest.fixture(scope="module")
def tiny(central, tmp_path_factory):
    """The tiny application (sends 'A') with 10 bytes of data EEPROM at 0x30, and the
    record for the central's bootloader."""
    out = tmp_path_factory.mktemp("tiny")
    subprocess.run(["gpasm", "-o", str(out / "tiny.hex"), str(FIXTURES / "tinyapp.asm")],
                   check=True, capture_output=True)
    ih = IntelHex(str(out / "tiny.hex"))
    for i in range(10):
        ih[EE_BASE + 0x30 + i] = 0xA0 + i
    add_record(ih, picboot.board_tag("papaman", "central"), "tiny")
    ih.write_hex_file(str(out / "tiny-app.hex"))
    return out / "tiny-app.hex"


class Chip:
    """The central's bootloader in gpsim and a line to it."""

    def __init__(self, central, workdir: Path):
        self.s = GpsimSession(workdir, timeout=600).start(
            central.folder / "build-boot" / "bootloader.cod", CLOCK)
        self.line = SimLine(self.s, workdir, CLOCK, picboot.BOOT_BAUD)
        self.boot = Bootloader(self.line, "gpsim", REPLY_S)

    def reset(self, baud: int = picboot.BOOT_BAUD) -> None:
        """A reset (power cycle) with a clean line."""
        self.line.fault = None
        self.s.command("reset")
        self.line.set_baud(baud)
        self.line.reset_input_buffer()

    def in_bootloader(self) -> bool:
        """After a reset and more than the hello window: does the bootloader answer?"""
        self.reset()
        self.line.sleep(2 * picboot.WINDOW_MS / 1000)
        try:
            self.boot.hello(0.5)
        except FlashError:
            return False
        return True

    def close(self) -> None:
        self.line.close()
        self.s.close()


@pytest.fixture
def chip(central, tmp_path):
    c = Chip(central, tmp_path)
    yield c
    c.close()


# -- gpsim's self-programming -----------------------------------------------------------
def test_gpsim_emulates_self_programming_with_the_unlock(tmp_path):
    """The reproducer (tests/fixtures/pic/selfprog.asm) erases the row at 0x1000 with
    TBLWT-less EECON1 (FREE), with and without the 55h/AAh sequence, and reads
    0x1008..0x100A back: gpsim erases only after the unlock (to 0x00, not 0xFF)."""
    got = {}
    for unlock in (0, 1):
        subprocess.run(["gpasm", f"-DUNLOCK={unlock}", "-o", str(tmp_path / f"sp{unlock}.hex"),
                        str(FIXTURES / "selfprog.asm")], check=True, capture_output=True)
        out = run_gpsim(f"load {tmp_path / f'sp{unlock}.cod'}\nfrequency 20000000\n"
                        "break c 200000\nrun\nreg(0x20)\nreg(0x21)\nreg(0x22)\n", tmp_path)
        got[unlock] = [int(v, 16) for v in re.findall(r"REG02[0-2]\S* = \$([0-9a-f]{2})", out)]
    assert got[0] == [0x99, 0xAA, 0xBB]          # no unlock: the row is untouched
    assert got[1] == [0x00, 0x00, 0x00]          # erased (gpsim's erased flash reads 0)


# -- the images ---------------------------------------------------------------------------
def test_the_bootloader_fills_the_boot_block_and_jumps_to_the_remapped_vectors(central):
    hexfile = central.folder / "bootloader.hex"
    assert central.boot.bootloader_bytes == program_bytes(hexfile) == BOOT_BYTES
    ih = IntelHex(str(hexfile))
    assert max(a for a in ih.addresses() if a < picboot.FLASH_END) < picboot.BOOT_END
    # BRA 0x0208 at 0x0008, BRA 0x0218 at 0x0018 (D0 + an 11-bit word offset)
    for vector in (0x08, 0x18):
        word = 0xD000 | (picboot.APP_START - 2) // 2
        assert [ih[vector], ih[vector + 1]] == [word & 0xFF, word >> 8]
    assert ih[0x30000B] & 0x40 == 0          # CONFIG6H WRTB: the boot block write-protected


def test_the_application_is_linked_above_it_with_exact_figures(central):
    app = IntelHex(str(central.folder / "firmware-app.hex"))
    flash = [a for a in app.addresses() if a < picboot.FLASH_END]
    assert min(flash) == picboot.APP_START and app[picboot.APP_START + 1] == 0xEF   # GOTO
    assert central.boot.app_bytes == central.usage.program_bytes     # same code, moved
    assert len([a for a in flash if a < picboot.RECORD]) == central.usage.program_bytes
    image = load_image(central.folder / "firmware-app.hex")
    assert image.end == central.boot.app_end and image.end % picboot.ROW == 0
    assert image.tag == picboot.board_tag("papaman", "central")
    assert central.boot.line("central") in summary_lines([central])
    assert f"application above it {central.usage.program_bytes} B" in central.boot.line("c")


# -- a whole application ---------------------------------------------------------------
def test_papaman_central_written_read_back_and_answering_v(central, chip):
    image = load_image(central.folder / "firmware-app.hex")
    phases = []
    write_image(chip.boot, image, lambda phase, pct: phases.append((phase, pct)))
    assert ("writing", 100) in phases and ("verifying", 100) in phases
    chip.line.set_baud(9600)                   # the application's line
    chip.line.timeout = 1.0
    chip.line.read(200)                        # its start-up notices
    chip.line.write(b"v\r")
    assert chip.line.read(200).startswith(b"OK esair-min/1 servos=12")
    # read back byte for byte, through the bootloader after a reset (in its window)
    chip.reset()
    chip.boot.hello(0.5)
    for address, data in [*image.rows.items(), (picboot.RECORD, image.record)]:
        assert chip.boot.exchange("R", address, reply=64) == data, hex(address)


# -- cut and damaged lines -----------------------------------------------------------
#: bytes the host sent before the cut (the 5-byte hello, the tiny app's 8 rows and its
#: EEPROM block in 69-byte frames, their 9 reads in 5-byte frames, the record): in the
#: first row, in the third, while verifying, inside the record's frame
CUTS = {"first row": 5 + 30, "third row": 5 + 2 * 69 + 10, "verifying": 5 + 9 * 69 + 12,
        "record": 5 + 9 * 69 + 9 * 5 + 40}


@pytest.mark.parametrize("where", sorted(CUTS))
def test_a_cut_flash_boots_into_the_bootloader_and_the_next_one_works(chip, tiny, where):
    image = load_image(tiny)
    chip.line.fault = LineFault(after=CUTS[where], cut=True)
    with pytest.raises(FlashError, match="drops or damages"):
        write_image(chip.boot, image, wait=1.0)
    assert chip.in_bootloader()
    write_image(chip.boot, image, wait=1.0)    # in the bootloader still: no window needed
    chip.line.timeout = 0.05
    assert chip.line.read(8) == b"AAAAAAAA"    # the application runs
    assert image.eeprom == {0: b"\xff" * 0x30 + bytes(range(0xA0, 0xAA)) + b"\xff" * 6}
    assert not chip.in_bootloader()            # and starts after a reset


def test_damaged_and_dropped_bytes_are_sent_again(chip, tiny):
    image = load_image(tiny)
    chip.line.fault = LineFault(after=5 + 69 + 20, damage=1)
    write_image(chip.boot, image, wait=1.0)
    chip.reset()
    chip.line.fault = LineFault(after=5 + 2 * 69 + 5, drop=3)
    write_image(chip.boot, image, wait=1.0)
    chip.line.timeout = 0.05
    assert chip.line.read(4) == b"AAAA"


def test_a_line_that_damages_every_frame_fails_and_leaves_the_bootloader(chip, tiny):
    chip.line.fault = LineFault(after=5 + 69 + 20, damage=10_000)
    with pytest.raises(FlashError, match=r"damaged frame \(checksum\).*after 3 tries"):
        write_image(chip.boot, load_image(tiny), wait=1.0)
    assert chip.in_bootloader()


# -- what the bootloader refuses -------------------------------------------------------
def test_the_bootloader_refuses_itself_past_the_flash_and_bad_frames(chip):
    line = chip.line
    chip.boot.hello(0.5)
    line.timeout = 1.0                          # 64 EEPROM bytes take 64 x 4 ms

    def ask(raw: bytes, n: int = 2) -> bytes:
        line.reset_input_buffer()
        line.write(raw)
        return line.read(n)

    for address in (0x0000, 0x01C0, 0x8000, 0x010200, 0x0210, EE_BASE + 0x20):
        assert ask(frame("W", address, b"\x55" * 64)) == b"A\xbf", hex(address)
    assert ask(frame("X")) == b"?\xc1"
    bad = bytearray(frame("W", 0x0200))
    bad[-1] ^= 1
    assert ask(bytes(bad)) == b"S\xad"
    # the data EEPROM: 64 bytes written and read back
    data = bytes(range(100, 164))
    assert ask(frame("W", EE_BASE + 0x40, data)) == b"K\xb5"
    assert chip.boot.exchange("R", EE_BASE + 0x40, reply=64) == data
    assert ask(frame("W", 0x0200, b"\x00" * 64)) == b"K\xb5"       # an application row


# -- the host's checks before and at the hello -------------------------------------------
def test_files_that_are_not_for_the_bootloader_are_refused(central, tmp_path):
    with pytest.raises(FlashError, match="overlap the bootloader"):
        load_image(central.folder / "firmware.hex")        # the programmer's image
    ih = IntelHex(str(central.folder / "firmware-app.hex"))
    ih[0x12000] = 0x55
    ih.write_hex_file(str(tmp_path / "other.hex"))
    with pytest.raises(FlashError, match="another chip"):
        load_image(tmp_path / "other.hex")
    ih = IntelHex(str(central.folder / "firmware-app.hex"))
    ih[0x0300] ^= 0xFF
    ih.write_hex_file(str(tmp_path / "edited.hex"))
    with pytest.raises(FlashError, match="does not match its contents"):
        load_image(tmp_path / "edited.hex")
    with pytest.raises(FlashError, match="cannot read"):
        load_image(tmp_path / "missing.hex")


def test_a_hex_for_another_board_is_refused_at_the_hello(chip, tiny, tmp_path):
    ih = IntelHex(str(tiny))
    for a in range(picboot.RECORD, picboot.FLASH_END):
        del ih[a]
    add_record(ih, picboot.board_tag("papaman", "sensor"), "tiny")
    ih.write_hex_file(str(tmp_path / "sensor.hex"))
    with pytest.raises(FlashError, match="built for another board"):
        write_image(chip.boot, load_image(tmp_path / "sensor.hex"), wait=1.0)
    assert chip.in_bootloader()


def test_another_chip_or_version_at_the_hello(tiny):
    image = load_image(tiny)
    check_hello(image, 0x0427, picboot.VERSION, image.tag, "p")        # a PIC18F452, rev 7
    with pytest.raises(FlashError, match="device id is 0x0C47, not a PIC18F452"):
        check_hello(image, 0x0C47, picboot.VERSION, image.tag, "p")
    with pytest.raises(FlashError, match="bootloader version 2"):
        check_hello(image, 0x0427, 2, image.tag, "p")


def test_no_bootloader_answering(tiny, tmp_path):
    import os
    import tty

    master, slave = os.openpty()
    tty.setraw(slave)
    try:
        with pytest.raises(FlashError, match="no bootloader answered on .* in 0.5 s"):
            flash_pic(tiny, os.ttyname(slave), baud=115200, connect_timeout=0.5)
    finally:
        os.close(master)
        os.close(slave)


# -- over a pty, as esair flash does it ----------------------------------------------------
def test_flash_pic_over_a_pty_to_the_gpsim_chip(central, tiny, tmp_path):
    """flash_pic on a real pty: gpsim behind it (esair_min.pic.gpsim_pty), paced to the
    wall clock; the tiny application then runs, its 'A's on that pty. (PAPA-MAN's whole
    central over such a pty, answering ``v``: tests/min/test_pic_flash_cli.py.)"""

    from esair_min.pic.gpsim_pty import GpsimPty

    phases = set()
    with GpsimPty(tmp_path, central.folder / "build-boot" / "bootloader.cod", CLOCK) as g:
        flash_pic(tiny, g.path, baud=picboot.BOOT_BAUD,
                  progress=lambda phase, pct: phases.add((phase, pct)))
        assert g.error is None
        assert {("writing", 100), ("verifying", 100)} <= phases
        with open_pty(g.path, picboot.BOOT_BAUD, timeout=0.2) as port:
            seen = b""
            for _ in range(100):
                seen += port.read(200)
                if b"A" * 16 in seen:
                    break
        assert b"A" * 16 in seen, seen
        assert g.error is None
