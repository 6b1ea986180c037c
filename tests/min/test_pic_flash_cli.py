"""``esair flash papaman --board central --port PTY`` against the simulated PIC: gpsim
running the central's generated bootloader behind a pty (``python -m
esair_min.pic.gpsim_pty``), as a user would try it (docs/bootloader.md). Needs the
toolchain."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tty
from pathlib import Path

import pytest
import serial

from esair_min.model.validate import load_robot
from esair_min.pic.build import BuildError, build_robot, toolchain
from esair_min.resources import resolve_robot

pytestmark = [pytest.mark.gpsim, pytest.mark.pty]

ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    try:
        tc = toolchain()
    except BuildError as exc:
        pytest.fail(str(exc), pytrace=False)
    out = tmp_path_factory.mktemp("build")
    build_robot(load_robot(resolve_robot("papaman")), out, tc, boot=True)
    return out


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
        assert "verifying" in proc.stderr
        with serial.Serial(port, 9600, timeout=0.2) as p:
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
    try:
        proc = esair("flash", "papaman", "--board", "central", "--port", os.ttyname(slave),
                     "-o", str(built))
    finally:
        os.close(master)
        os.close(slave)
    assert proc.returncode == 1
    assert "no bootloader answered" in proc.stderr and "Traceback" not in proc.stderr
