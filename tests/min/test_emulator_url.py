"""The esair:// pySerial URL handler: an in-process emulator that behaves as a port."""

from __future__ import annotations

import time

import pytest
import serial

import esair_min.emulator  # noqa: F401  (registers esair://)
from esair_min.emulator.protocol_esair import parse_url
from tests.support.board_lines import READY_BAD, READY_OK, VERSION_BAD, VERSION_OK

VERSION = VERSION_OK


def test_registered_with_pyserial():
    assert "esair_min.emulator" in serial.protocol_handler_packages


def test_max_speed_port_answers_like_the_robot():
    port = serial.serial_for_url("esair://boards/papaman?speed=max", timeout=1)
    try:
        assert port.readline() == READY_OK
        port.write(b"v\r\n")
        assert port.readline() == VERSION
        port.write(b"t\r\noab100\r\nzz\r\nPLY03\r\nt\r\n")
        assert [port.readline() for _ in range(5)] == [
            b"OK\r\n", b"OK\r\n", b"E01 unknown command\r\n", b"OK\r\n", b"E07 busy\r\n"]
        assert port.read(10) == b""             # nothing more: times out (virtual second)
        port.write(b"s\r\n")
        assert port.in_waiting == len(b"OK 512,512,512,512,512,512,512,512\r\n")
        emu = port.emulator          # the dance has ended during the second waited
        assert emu.playing is None
        assert emu.servo_angles == [84, 82, 90, 94, 90, 98, 96, 82, 90, 94, 90, 98]
    finally:
        port.close()
    assert not port.is_open


def test_url_options_scenario_faults_and_trace(tmp_path):
    trace = tmp_path / "t.txt"
    port = serial.serial_for_url(
        f"esair://papaman?speed=max&scenario=push&nack=actuator&trace={trace}", timeout=2)
    try:
        port.readline()
        port.write(b"t\r\n")
        assert port.readline() == b"E10 no answer on i2c\r\n"
        port.read(1000)                         # two virtual seconds: the push comes
        port.write(b"s\r\n")
        assert port.readline() == b"OK 512,512,512,512,512,512,512,512\r\n"
    finally:
        port.close()
    text = trace.read_text()
    assert text.startswith("# esair-trace 1\n@ 0\nR 50 0000 8 ")
    assert "TX " + b"!R auto_balance\r\n".hex().upper() in text


def test_url_stuck_bus():
    port = serial.serial_for_url("esair://papaman?speed=max&stuck=bus", timeout=2)
    try:
        assert port.readline() == READY_BAD
        port.write(b"v\r\nt\r\n")
        # the two replies, and the balance poll's notice (once) where its tick fell
        lines = [port.readline() for _ in range(3)]
        assert [x for x in lines if not x.startswith(b"!")] == [VERSION_BAD,
                                                               b"E10 no answer on i2c\r\n"]
        assert [x for x in lines if x.startswith(b"!")] == [b"!E10 no answer on i2c\r\n"]
    finally:
        port.close()


def test_real_time_port_takes_line_time():
    port = serial.serial_for_url("esair://papaman", timeout=2)
    try:
        assert port.readline() == READY_OK
        line_s = (2 + len(VERSION)) * 10 / 9600    # "v" CR, then the reply, at 9600 baud
        v0, t0 = port.emulator.clock.now, time.monotonic()
        port.write(b"v\r\n")
        assert port.readline() == VERSION
        # the robot's own time passed the line time; the wall clock never less than that
        # (virtual time follows the wall clock: it is never ahead), however loaded
        assert (port.emulator.clock.now - v0) / 1e9 >= line_s
        assert time.monotonic() - t0 >= line_s - 0.005   # 5 ms: the pacer's step
        port.reset_input_buffer()
        assert port.in_waiting == 0
    finally:
        port.close()


def test_parse_url():
    assert parse_url("esair://boards/papaman?speed=max&seed=3") == (
        "boards/papaman", {"speed": "max", "seed": "3"})
    assert parse_url("esair:///abs/robot") == ("/abs/robot", {})


@pytest.mark.parametrize("url, message", [
    ("esair://papaman?colour=red", "unknown option 'colour' in 'esair://papaman?colour=red' "
     "(known: speed, scenario, trace, nack, absent, corrupt, stuck, noise, seed, "
     "eeprom)"),
    ("esair://?speed=max", "esair:// URL names no robot (e.g. esair://boards/papaman)"),
    ("esair://papaman?speed=fast", "speed='fast': use real, max or a factor > 0"),
    ("esair://papaman?nack=sensor", "option nack='sensor': only nack=actuator exists"),
    ("esair://papaman?stuck=sda", "option stuck='sda': only stuck=bus exists"),
    ("esair://papaman?noise=lots", "bad number in URL options: could not convert string to "
     "float: 'lots'"),
    ("esair://papaman?scenario=pusj", "cannot start the emulator: no scenario 'pusj' (did you "
     "mean 'push'?): give a file, or one of the robot's scenarios (push, quiet)"),
    ("esair://no/such/robot", "cannot start the emulator: no/such/robot: no such file or "
     "folder"),
])
def test_url_errors(url, message):
    with pytest.raises(serial.SerialException) as exc:
        serial.serial_for_url(url)
    assert str(exc.value) == message


def test_real_time_port_cancel_read_ends_a_waiting_read():
    """cancel_read (pySerial's, which the MIN link uses to wake its I/O thread) ends a
    read that would otherwise wait for ever, from another thread or before the read."""
    import threading

    port = serial.serial_for_url("esair://boards/papaman", timeout=None)
    try:
        port.reset_input_buffer()               # the !READY: nothing else will come
        got: list[bytes] = []
        reader = threading.Thread(target=lambda: got.append(port.read(1)), daemon=True)
        reader.start()
        reader.join(0.2)
        assert reader.is_alive()                # waiting: the robot sends nothing
        port.cancel_read()
        reader.join(30)
        assert not reader.is_alive() and got == [b""]
        port.cancel_read()                      # before the read: the next one ends at once
        reader = threading.Thread(target=lambda: got.append(port.read(1)), daemon=True)
        reader.start()
        reader.join(30)
        assert not reader.is_alive() and got == [b"", b""]
        port.timeout = 2                        # and the port still answers
        port.write(b"x\r\n")
        assert port.readline() == b"OK\r\n"
    finally:
        port.close()
