"""``esair flash`` end to end with no hardware (issue 32): simavr runs an Arduino's
ATmega328P whose flash holds a real bootloader (Optiboot built from Debian's
optiboot.c, or Debian's ATmegaBOOT .hex as shipped), in real time, its USART on a pty
(esair_min/avr/uno.py); the real avrdude writes and verifies through it, the chip then
boots the written firmware, which answers ``v``. Each fault gives a message naming the
likely cause and a non-zero exit. Marked ``avr``.
"""

from __future__ import annotations

import os
import re
import pty
import subprocess
import sys
import time
from pathlib import Path

import pytest

from esair_min.avr.uno import SimUno, new_chip, read_flash_hex
from esair_min.model.validate import load_robot
from esair_min.serialport import open_port
from tests.support.monitoring import run_until_monitoring

pytestmark = pytest.mark.avr

ROOT = Path(__file__).resolve().parents[2]
BOARDS = ROOT / "boards" / "papaman-avr"
ENV = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))


@pytest.fixture(scope="module")
def build(tmp_path_factory) -> Path:
    """papaman-avr generated and its central board built once (``esair build``'s steps):
    every flash here is the central's, and esair flash/run check only the flashed
    board's .hex."""
    from esair_min.avr.build import build_board
    from esair_min.codegen import generate_robot

    out = tmp_path_factory.mktemp("build")
    generate_robot(load_robot(BOARDS), out)
    build_board(out / "central")
    return out


def esair(*args: str, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "esair_min.cli", *args], capture_output=True,
                          text=True, timeout=timeout, env=ENV, stdin=subprocess.DEVNULL)


def flash(port: Path, build: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    return esair("flash", str(BOARDS), "--board", "central", "--port", str(port), "-o",
                 str(build), "--attempts", "1", *extra)


#: A flash that must succeed, as a user runs it: `esair flash`'s own attempts (on
#: a busy machine the simulated chip can answer avrdude's sync late, once)
AS_A_USER = ("--attempts", "3")


def holds(uno: SimUno, hex_path: Path) -> bool:
    """The chip's flash holds every byte of the .hex."""
    data = uno.flash_bytes()
    return all(data[a] == v for a, v in read_flash_hex(hex_path, len(data)).items())


def answers_v(port: Path, timeout: float = 30) -> str:
    """Open the board's port at the app's 9600 baud (which resets it), wait for its
    !READY, send ``v``; the reply."""
    ser = open_port(str(port), baudrate=9600, timeout=0.2)
    try:
        buf = b""
        deadline = time.monotonic() + timeout
        while b"!READY" not in buf and time.monotonic() < deadline:
            buf += ser.read(64)
        assert b"!READY" in buf, buf
        ser.write(b"v\r\n")
        buf = b""
        while time.monotonic() < deadline:
            buf += ser.read(64)
            done = buf.decode("latin-1").rpartition("\n")[0]
            lines = [ln for ln in done.splitlines() if ln.startswith("OK")]
            if lines:
                return lines[0]
        raise AssertionError(f"no reply to v: {buf!r}")
    finally:
        ser.close()


def test_the_old_nano_bootloader_as_debian_ships_it(build, tmp_path):
    chip = tmp_path / "flash.bin"
    boot = new_chip(chip, "atmegaboot")
    with SimUno(chip, tmp_path / "ttyNANO", boot) as uno:
        r = flash(uno.port, build, "--bootloader", "atmegaboot", *AS_A_USER)
        assert r.returncode == 0, r.stderr
        assert holds(uno, build / "central" / "firmware.hex")


def test_nothing_answers_a_chip_without_bootloader(build, tmp_path):
    chip = tmp_path / "flash.bin"
    with SimUno(chip, tmp_path / "ttyBARE", new_chip(chip, None)) as uno:
        r = flash(uno.port, build)
    assert r.returncode == 1
    assert "error: no bootloader answered" in r.stderr
    assert "wrong port" in r.stderr and "--bootloader atmegaboot" in r.stderr
    assert "Traceback" not in r.stderr and "verified" not in r.stdout


def test_the_wrong_baud_says_to_try_the_other_bootloader(build, tmp_path):
    chip = tmp_path / "flash.bin"
    with SimUno(chip, tmp_path / "ttyUNO", new_chip(chip, "optiboot")) as uno:
        r = flash(uno.port, build, "--bootloader", "atmegaboot")
        assert r.returncode == 1
        assert "at 57600 baud" in r.stderr and "--bootloader optiboot" in r.stderr
        assert all(b == 0xFF for b in uno.flash_bytes()[:0x7E00])


def test_another_chips_signature(build, tmp_path):
    chip = tmp_path / "flash.bin"
    boot = new_chip(chip, "optiboot168")
    with SimUno(chip, tmp_path / "tty168", boot, part="atmega168") as uno:
        r = flash(uno.port, build)
        assert r.returncode == 1
        assert "is ATmega168 (signature 1E9406), not the ATmega328P" in r.stderr
        assert all(b == 0xFF for b in uno.flash_bytes()[:0x3E00])


def test_a_byte_damaged_fails_the_verify_then_optiboot_writes_verifies_and_the_chip_answers_v(
        build, tmp_path):
    """One byte damaged on the line: the verify fails, nothing runs. The chip powered on
    again, the next flash (as a user runs it) writes and verifies the whole .hex over the
    damaged image, the bootloader untouched, and the chip then boots the firmware, which
    answers ``v`` on the same port at 9600 baud."""
    chip = tmp_path / "flash.bin"
    boot = new_chip(chip, "optiboot")
    assert boot == 0x7E00
    loader = chip.read_bytes()[0x7E00:]
    hex_path = build / "central" / "firmware.hex"
    # the 2000th byte from the host lies in a page's data (avrdude 7.1's STK500 stream)
    with SimUno(chip, tmp_path / "ttyUNO", boot, damage_at=2000) as uno:
        r = flash(uno.port, build)
        assert uno.wait_for("damaged", 5)
        assert r.returncode == 1
        assert "verify failed" in r.stderr and "damaged on the line" in r.stderr
        assert not holds(uno, hex_path)
    with SimUno(chip, tmp_path / "ttyUNO", boot) as uno:
        r = flash(uno.port, build, *AS_A_USER)
        assert r.returncode == 0, r.stderr
        assert "written to" in r.stdout and "verified" in r.stdout
        assert "writing: 100%" in r.stderr and "verifying: 100%" in r.stderr
        assert f"built {build}" not in r.stderr           # the fixture's build was taken
        assert holds(uno, hex_path)
        assert uno.flash_bytes()[0x7E00:] == loader
        assert answers_v(uno.port).startswith("OK esair-min/1 servos=12 sensors=8 motions=5")


def test_the_cable_pulled_mid_write_then_the_next_flash_succeeds(build, tmp_path):
    chip = tmp_path / "flash.bin"
    boot = new_chip(chip, "optiboot")
    loader = chip.read_bytes()[0x7E00:]
    hex_path = build / "central" / "firmware.hex"
    with SimUno(chip, tmp_path / "ttyUNO", boot) as uno:
        proc = subprocess.Popen([sys.executable, "-m", "esair_min.cli", "flash", str(BOARDS),
                                 "--board", "central", "--port", str(uno.port), "-o",
                                 str(build), *AS_A_USER], env=ENV, text=True,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        # (the attempts are avrdude's to reach the bootloader: a write cut off is not tried again)
        assert uno.wait_for("page", 60, test=lambda f: int(f[2]) >= 2048)
        uno.kill()
        out, err = proc.communicate(timeout=120)
    assert proc.returncode == 1, err
    assert "stopped answering during the write" in err and "bootloader is untouched" in err
    assert "verified" not in out
    assert chip.read_bytes()[0x7E00:] == loader
    with SimUno(chip, tmp_path / "ttyUNO", boot) as uno:      # power on again
        r = flash(uno.port, build, *AS_A_USER)
        assert r.returncode == 0, r.stderr
        assert holds(uno, hex_path)


def test_a_port_another_program_holds_is_refused_with_who(build, tmp_path):
    master, slave = pty.openpty()
    name = os.ttyname(slave)
    holder = subprocess.Popen(
        [sys.executable, "-c", "import sys; from esair_min.serialport import open_port; "
         f"s = open_port({name!r}, baudrate=9600); print('held', flush=True); sys.stdin.read()"],
        env=ENV, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "held"
        r = flash(Path(name), build)
        assert r.returncode == 1
        assert f"{name} is in use" in r.stderr and f"pid {holder.pid}" in r.stderr
        assert "esair_min.serialport" in r.stderr
    finally:
        holder.kill()
        holder.wait()
        os.close(master)
        os.close(slave)


def test_dry_run_prints_the_avrdude_command_and_fuses_come_from_the_clock(build):
    r = esair("flash", str(BOARDS), "--board", "central", "--port", "/dev/ttyUSB7", "-o",
              str(build), "--dry-run")
    assert r.returncode == 0, r.stderr
    hex_path = build / "central" / "firmware.hex"
    assert r.stdout.strip() == ("avrdude -p m328p -c arduino -P /dev/ttyUSB7 -b 115200 "
                                f"-x attempts=3 -D -Uflash:w:{hex_path}:i")
    r = esair("flash", str(BOARDS), "--board", "central", "--port", "usb", "-o", str(build),
              "--programmer", "usbasp", "--fuses", "--dry-run")
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip().endswith("-Ulfuse:w:0xFF:m -Uhfuse:w:0xD9:m -Uefuse:w:0xFD:m")
    assert "16 MHz crystal" in r.stderr
    r = esair("flash", str(BOARDS), "--board", "central", "--port", "/dev/ttyUSB7", "-o",
              str(build), "--fuses", "--dry-run")
    assert r.returncode == 1 and "--fuses needs --programmer" in r.stderr


def test_a_missing_or_stale_hex_is_built_first(tmp_path):
    from esair_min.flash.firmware import firmware

    boards = tmp_path / "robot"
    boards.mkdir()
    for f in BOARDS.glob("*.yaml"):
        (boards / f.name).write_bytes(f.read_bytes())
    robot = load_robot(boards)
    fw = firmware(robot, tmp_path / "build", "central")
    assert fw.built and fw.hex_path.exists()
    assert not firmware(robot, tmp_path / "build", "central").built
    later = fw.hex_path.stat().st_mtime + 5
    os.utime(boards / "sensor.yaml", (later, later))
    assert firmware(robot, tmp_path / "build", "central").built


def test_debians_optiboot_hex_does_not_fit_the_boot_section():
    """Why the simulated Uno's Optiboot is built from Debian's optiboot.c without the LED
    flashes: the .hex Debian ships is 532 bytes from 0x7E00, past the end of flash."""
    from esair_min.avr.simavr_harness import SimError
    from esair_min.avr.uno import BOOTLOADERS

    shipped = BOOTLOADERS / "optiboot" / "optiboot_atmega328.hex"
    with pytest.raises(SimError, match="data at 0x8013, beyond the 32768-byte flash"):
        read_flash_hex(shipped, 32768)


def run_until_motions(port: Path, build: Path, *extra: str) -> tuple[int, str, str]:
    """``esair run papaman-avr --port PORT`` until it monitors (the motions written or
    skipped), then Ctrl-C (SIGINT): (status, stdout, stderr)."""
    return run_until_monitoring(["run", str(BOARDS), "--port", str(port), "-o", str(build),
                                 "--attempts", "1", *extra], ENV)


def ready_line(port: Path, timeout: float = 30) -> str:
    """The !READY the board sends when its port is opened (which resets it)."""
    ser = open_port(str(port), baudrate=9600, timeout=0.2)
    try:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            line = ser.readline().decode("latin-1")
            if line.startswith("!READY") and line.endswith("\n"):
                return line.strip()
        raise AssertionError("no !READY")
    finally:
        ser.close()


def test_run_flashes_writes_the_motions_then_monitors_and_skips_what_is_done(build, tmp_path):
    """esair run against the simulated Uno with a blank 24LC256 on its TWI: flash, the
    motions over the link, the monitor; run again: the build id matches, the image's CRC
    too, nothing is written."""
    chip = tmp_path / "flash.bin"
    boot = new_chip(chip, "optiboot")
    with SimUno(chip, tmp_path / "ttyUNO", boot, eeprom=tmp_path / "ee.bin") as uno:
        # a chip holding only its bootloader never says !READY: 1 s to find it out
        status, out, err = run_until_motions(uno.port, build, "--wait", "1")
        assert status == 130, err
        assert f"built {build}" not in err                # the fixture's build was taken
        assert re.search(r"central: \d+ bytes written to", out)
        assert re.search(r"motions: wrote (\d+) of \1 chunks", out)
        assert "monitor stopped" in err and "Traceback" not in err
        assert holds(uno, build / "central" / "firmware.hex")
        assert re.fullmatch(r"!READY esair-min/1 image=ok crc=[0-9A-F]{4} build=[0-9a-f]{8}",
                            ready_line(uno.port))
        status, out, err = run_until_motions(uno.port, build)     # nothing changed
        assert status == 130, err
        assert re.search(r"central: \S+ already runs build [0-9a-f]{8}: not flashed", out)
        assert "motions: the robot already holds them" in out
        assert "written to" not in out and "wrote" not in out
