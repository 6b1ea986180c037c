"""``esair doctor``: a healthy emulated PAPA-MAN passes every check, and each injected
fault fails the check it belongs to, with its hint and exit status 1 (issue 32 item 4)."""

from __future__ import annotations

import os
import pty
import signal
import subprocess
import sys
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

import pytest
import serial

from esair_min.core.image import build_image
from esair_min.model.validate import load_robot

pytestmark = [pytest.mark.pty, pytest.mark.slow]

ROOT = Path(__file__).resolve().parents[2]
PAPAMAN = ROOT / "boards" / "papaman"


@contextmanager
def emulated(robot: str | Path, *args: str) -> Iterator[str]:
    """``esair emulate ROBOT --pty ARGS``: its port's path while it serves."""
    proc = subprocess.Popen([sys.executable, "-m", "esair_min.cli", "emulate", str(robot),
                             "--pty", *args], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        path = proc.stdout.readline().strip()
        assert path.startswith("/dev/"), proc.stderr.read()
        yield path
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.wait(timeout=30)
        proc.stdout.close()
        proc.stderr.close()


def doctor(port: str, *args: str, robot: str = "papaman") -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "esair_min.cli", "doctor", robot,
                           "--port", port, *args], cwd=ROOT, capture_output=True,
                          text=True, timeout=120)


def failed(out: str) -> list[str]:
    """The FAIL lines, each with its hint line."""
    lines = out.splitlines()
    return [f"{ln}\n{lines[i + 1] if i + 1 < len(lines) else ''}"
            for i, ln in enumerate(lines) if ln.startswith("FAIL")]


def copy(tmp_path: Path, name: str, edit) -> Path:
    """PAPA-MAN's board files copied into ``tmp_path/name``, ``edit(file, text)`` applied."""
    folder = tmp_path / name
    folder.mkdir()
    for path in PAPAMAN.glob("*.yaml"):
        (folder / path.name).write_text(edit(path.name, path.read_text()))
    return folder


def test_a_healthy_robot_passes_every_check_and_moves_each_servo():
    with emulated("papaman") as port:
        r = doctor(port, "--move")
    assert r.returncode == 0, r.stdout + r.stderr
    lines = r.stdout.splitlines()
    assert failed(r.stdout) == []
    assert lines[0] == f"PASS  port: {port} opened at 9600 baud"
    assert "PASS  reply: the board answers 'v' at 9600 baud" in lines
    assert "PASS  robot: papaman's central board: 12 servos, 8 sensors, 5 motions" in lines
    assert "PASS  motions: the image of these board files (CRC 2C20)" in lines
    assert [ln for ln in lines if ln.startswith("PASS  i2c")] == [
        "PASS  i2c: eeprom 'motion_store' at 0x50 answers",
        "PASS  i2c: board 'servos' at 0x10 answers",
        "PASS  i2c: board 'feet' at 0x20 answers"]
    assert "PASS  sensors: 8 readings inside their ranges" in lines
    moved = [ln for ln in lines if ln.startswith("PASS  move")]
    assert len(moved) == 12 and moved[0] == (
        "PASS  move: l_hip_yaw moved to 95, 85 and back to 90 degrees")
    assert lines[-1] == "papaman: all checks passed"


def test_an_absent_slave_is_named_with_its_address():
    with emulated("papaman", "--no-sensor") as port:
        r = doctor(port)
    assert r.returncode == 1
    assert failed(r.stdout)[0] == (
        "FAIL  i2c: board 'feet' at 0x20 does not answer\n"
        "      hint: check its power, its SDA/SCL wires, the pull-ups (one pair of about "
        "4.7 kOhm to the logic supply) and its address (the board file says 0x20)")
    assert r.stdout.splitlines()[-1] == "papaman: 2 failed"      # and the sensors' read


def test_a_bad_image_and_a_stale_one_say_to_write_the_motions(tmp_path):
    with emulated("papaman", "--corrupt-eeprom") as port:
        r = doctor(port)
    assert r.returncode == 1
    assert failed(r.stdout) == [
        "FAIL  motions: the robot holds no valid motion image (image=bad)\n"
        f"      hint: write it: esair eeprom papaman --write {port}"]
    # another robot's motions (one frame angle changed), valid: the CRC tells them apart
    other = load_robot(copy(tmp_path, "other", lambda name, text: text.replace(
        "[90, 90, 90, 90, 90, 90", "[91, 90, 90, 90, 90, 90", 1)))
    image = build_image(other)
    assert image != build_image(load_robot(PAPAMAN))
    chip = tmp_path / "eeprom.bin"
    chip.write_bytes(image + b"\xff" * (32768 - len(image)))
    with emulated("papaman", "--eeprom", str(chip)) as port:
        r = doctor(port)
    assert r.returncode == 1
    [line] = failed(r.stdout)
    assert line.startswith("FAIL  motions: the robot's motion image (CRC ")
    assert line.endswith(f"is not the one these board files build (CRC 2C20)\n"
                         f"      hint: write it: esair eeprom papaman --write {port}")


def test_a_wrong_baud_names_the_baud_that_answers(tmp_path):
    fast = copy(tmp_path, "fast", lambda name, text: text.replace(
        "baud: 9600", "baud: 19200") if name == "central.yaml" else text)
    assert load_robot(fast).central.uart.baud == 19200
    with emulated(fast, "--strict-baud") as port:
        r = doctor(port)
    assert r.returncode == 1
    assert failed(r.stdout) == [
        "FAIL  reply: no reply at 9600 baud (the board file's); the board answers at "
        "19200 baud\n"
        "      hint: the firmware on the board was built for 19200 baud: flash the one "
        f"these board files build (esair flash papaman --board central --port {port}), or "
        "set the central board's uart baud to 19200"]


def test_another_robots_board_is_named():
    with emulated("starfish") as port:
        r = doctor(port, "--timeout", "1")
    assert r.returncode == 1
    assert failed(r.stdout) == [
        "FAIL  robot: the board answers as robot 'starfish', not as papaman's central "
        "board (12 servos, 8 sensors, 5 motions)\n"
        "      hint: another robot's firmware, or another robot on this port: flash "
        f"papaman's (esair flash papaman --board central --port {port})"]


def test_no_robot_and_a_held_port():
    master, slave = pty.openpty()
    path = os.ttyname(slave)
    try:
        r = doctor(path, "--timeout", "0.3")
        assert r.returncode == 1
        assert failed(r.stdout) == [
            "FAIL  reply: nothing answers 'v' (tried 9600, 19200, 38400, 57600, 115200, "
            "4800, 2400 baud)\n"
            "      hint: check that this is the robot's port, the cable (TX to RX, RX to "
            "TX, GND joined; an RS-232 board needs its level shifter), the board's power, "
            "and that ESAIR's firmware is on it (esair flash)"]
        with serial.Serial(path, 9600, exclusive=True):
            r = doctor(path)
        assert r.returncode == 1
        [line] = failed(r.stdout)
        assert line.startswith(f"FAIL  port: {path}: held by pid {os.getpid()} (")
        assert line.endswith("      hint: stop that program first (or use its own commands)")
    finally:
        os.close(master)
        os.close(slave)
    r = doctor("/dev/esair-no-such-port")
    assert r.returncode == 1 and "check the port's name" in r.stdout


def test_strict_baud_is_refused_without_pty():
    r = subprocess.run([sys.executable, "-m", "esair_min.cli", "emulate", "papaman",
                        "--run", "0.1", "--strict-baud"], cwd=ROOT, capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 1
    assert "--strict-baud works with --pty only" in r.stderr

