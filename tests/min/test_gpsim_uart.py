"""The central board's UART under load: the PIC firmware in gpsim and the emulator.

A burst of command lines whose replies are longer than the lines cannot all be
answered at 9600 baud: the replies wait for room in the 80-byte transmit ring, the
superloop waits with them, and the 64-byte receive ring overruns. The emulator models
that wait (esair_min/emulator/uart.py), so PC software sees there what the board does.
"""

from __future__ import annotations

import pytest

from esair_min.emulator import Emulator
from esair_min.pic.gpsim_harness import run_stimulus

pytestmark = [pytest.mark.gpsim, pytest.mark.pty]

LINES = ["t", "oab100", "v", "s", "zz", "a" + "002" * 12, "c" + "N" * 12, "x", "oab095",
         "PLY09", "t", "oal100"] * 3
READING = 514            # a value gpsim's sensor stand-in can return (docs/toolchain.md)


def _replies(data: bytes) -> list[str]:
    return [r for r in data.decode("latin-1").split("\r\n")[:-1] if not r.startswith("!")]


def test_a_burst_overruns_the_same_way_on_the_pic_and_in_the_emulator(robot, pic_firmware,
                                                                        tmp_path):
    burst = "".join(line + "\\r\\n" for line in LINES)
    stimulus = f"sensor {' '.join([str(READING)] * 8)}\nboot\ntick 4\nrx {burst}\ntick 300\n"
    cod = pic_firmware("central") / "build-pic" / "firmware.cod"
    run = run_stimulus(robot, stimulus, cod, tmp_path)
    pic = _replies(bytes(v for _, v in run.tx))

    emu = Emulator(robot)
    emu.settle()
    emu.read()
    emu.sensor_slave.set_readings((READING,) * 8)
    emu.write(b"".join(line.encode() + b"\r\n" for line in LINES))
    emu.run_for(3.0)
    emulated = _replies(emu.read())

    for replies in (pic, emulated):
        assert "E12 input overrun" in replies
        assert 20 <= len(replies) < len(LINES)
    assert abs(len(pic) - len(emulated)) <= 2
    # equal up to the first overrun (the PIC and the emulator overrun a reply apart;
    # without the transmit-ring wait the emulator would answer every line)
    first = min(pic.index("E12 input overrun"), emulated.index("E12 input overrun"))
    assert first >= 12 and emulated[:first] == pic[:first]
