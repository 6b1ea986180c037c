"""``esair flash papaman --board central --port PTY`` against the simulated PIC: gpsim
running the central's generated bootloader behind a pty (``python -m
esair_min.pic.gpsim_pty``), as a user would try it (docs/bootloader.md). Needs the
toolchain."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import tty
from pathlib import Path

import pytest

from tests.support.monitoring import run_until_monitoring
from tests.support.robot_ptys import open_pty

pytestmark = [pytest.mark.gpsim, pytest.mark.pty]

ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}


@pytest.fixture(scope="module")
def built(papaman_boot):
    """The build folder (-o): PAPA-MAN generated, its central built with the bootloader
    (tests/conftest.py); esair flash and esair run check only the flashed board's .hex."""
    return papaman_boot.folder.parent


def esair(*args: str, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "esair_min.cli", *args], capture_output=True,
                          text=True, timeout=timeout, env=ENV, stdin=subprocess.DEVNULL,
                          cwd=ROOT)


def test_esair_flash_writes_verifies_and_boots_the_central(built):
    sim = subprocess.Popen([sys.executable, "-m", "esair_min.pic.gpsim_pty",
                            str(built / "central")], stdout=subprocess.PIPE, text=True,
                           env=ENV, stdin=subprocess.DEVNULL)
    try:
        assert sim.stdout is not None
        line = sim.stdout.readline()
        assert line.startswith("pty: "), line
        port = line.split()[1]
        proc = esair("flash", "papaman", "--board", "central", "--port", port,
                     "-o", str(built))
        assert proc.returncode == 0, proc.stderr
        assert "written to" in proc.stdout and "verified" in proc.stdout
        assert "writing: 100%" in proc.stderr and "verifying: 100%" in proc.stderr
        assert f"built {built}" not in proc.stderr        # the fixture's build was taken
        with open_pty(port, 9600, timeout=0.2) as p:
            seen = b""
            for _ in range(100):
                p.write(b"v\r")
                seen += p.read(200)
                if b"OK esair-min/1 servos=12" in seen:
                    break
        assert b"OK esair-min/1 servos=12" in seen, seen
    finally:
        sim.send_signal(signal.SIGTERM)
        sim.wait(timeout=60)


def test_esair_flash_with_no_bootloader_answering_exits_non_zero(built):
    master, slave = os.openpty()
    tty.setraw(slave)
    name = os.ttyname(slave)
    try:
        proc = esair("flash", "papaman", "--board", "central", "--port", name,
                     "-o", str(built), "--wait", "1.5")
    finally:
        os.close(master)
        os.close(slave)
    assert proc.returncode == 1
    assert f"no bootloader answered on {name} in 1.5 s" in proc.stderr
    assert "Traceback" not in proc.stderr


def test_esair_run_flashes_a_blank_pic_writes_the_motions_then_skips_what_is_done(built):
    """A chip holding only its bootloader, a blank 24LC256 on its bus: esair run flashes
    the central through the bootloader, writes the motions over the robot's link and
    monitors; run again, the build id (the v reply's: a PIC is not reset by opening its
    port) and the image's CRC match and nothing is written."""
    sim = subprocess.Popen([sys.executable, "-m", "esair_min.pic.gpsim_pty",
                            str(built / "central"), "--eeprom"], stdout=subprocess.PIPE,
                           text=True, env=ENV, stdin=subprocess.DEVNULL)
    try:
        assert sim.stdout is not None
        line = sim.stdout.readline()
        assert line.startswith("pty: "), line
        port = line.split()[1]
        run = ["run", "papaman", "--port", port, "-o", str(built)]
        # a chip holding only its bootloader never answers v: 1 s to find it out
        status, out, err = run_until_monitoring([*run, "--wait", "1"], ENV, ROOT)
        assert status == 130, out + err
        assert "central: written to" in out and "verified" in out
        assert "motions: wrote 67 of 67 chunks (1070 bytes)" in out, out
        assert "Traceback" not in err
        status, out, err = run_until_monitoring(run, ENV, ROOT)
        assert status == 130, out + err
        assert re.search(r"central: \S+ already runs build [0-9a-f]{8}: not flashed", out), out
        assert "motions: the robot already holds them (CRC 0x2C20)" in out, out
    finally:
        sim.send_signal(signal.SIGTERM)
        sim.wait(timeout=60)
