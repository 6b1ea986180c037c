"""The gpsim harness's stimulus lines (esair_min/pic/gpsim_harness.py, one function a
verb): each verb's gpsim commands and each refusal word for word. Only the command file
is built here (no gpsim run: tests/min/test_gpsim.py runs them)."""

from __future__ import annotations

import pytest

from esair_min.errors import ProtocolError
from esair_min.model.validate import load_robot
from esair_min.pic.gpsim_harness import build_script


@pytest.fixture(scope="module")
def papaman():
    return load_robot("boards/papaman")


def commands(robot, stimulus: str) -> list[str]:
    """The command lines the stimulus adds after the setup and before the epilogue."""
    bare, _ = build_script(robot, "boot\n", "fw.cod", "image.hex")
    full, _ = build_script(robot, "boot\n" + stimulus, "fw.cod", "image.hex")
    head, tail = bare.splitlines(), full.splitlines()
    cut = len(head) - 6                     # the epilogue: log off ... quit
    assert tail[:cut] == head[:cut] and tail[-6:] == head[-6:]
    return tail[cut:-6]


def test_each_verb_writes_its_gpsim_commands(papaman):
    assert commands(papaman, "rx  t\\r\n") == ["U1.tx = 0x20", "U1.tx = 0x74", "U1.tx = 0x0d"]
    assert commands(papaman, "poke 10 ff\n") == ["EE.eeData[0x10] = 0xff"]
    assert commands(papaman, "sensor " + " ".join(["257"] * 8) + "\n") == [
        f"PS{i}.voltage = {5.0 if i == 0 else 0.0}" for i in range(8)]
    assert commands(papaman, "fault sensor on\nfault sensor off\n") == [
        "SEN.Slave_Address = 0x7f", "SEN.Slave_Address = 0x20"]
    # the boot wait ends at cycle 1 285 760; a tick is 44 928 cycles
    assert commands(papaman, "tick 2\n") == ["break c 1375616", "run"]
    assert commands(papaman, "tick\nfault bus on\n")[:2] == ["break c 1330688", "run"]


@pytest.mark.parametrize("stimulus, message", [
    ("rx t\n", "stimulus line 1: rx before boot"),
    ("boot\nboot\n", "stimulus line 2: a second boot is not supported in gpsim"),
    ("boot\nboot x\n", "stimulus line 2: 'boot x' is not supported by the gpsim harness "
     "(boot, rx, tick, sensor, fault sensor|bus|sda, poke)"),
    ("boot\ntick 1 2\n", "stimulus line 2: 'tick 1 2' is not supported by the gpsim harness "
     "(boot, rx, tick, sensor, fault sensor|bus|sda, poke)"),
    ("boot\nsensor\n", "stimulus line 2: 'sensor' is not supported by the gpsim harness "
     "(boot, rx, tick, sensor, fault sensor|bus|sda, poke)"),
    ("boot\nsensor 257 514\n", "stimulus line 2: gpsim's sensor stand-in returns one byte "
     "for every register: all readings must be equal"),
    ("boot\npoke 1\n", "stimulus line 2: 'poke 1' is not supported by the gpsim harness "
     "(boot, rx, tick, sensor, fault sensor|bus|sda, poke)"),
    ("boot\nfoo\n", "stimulus line 2: 'foo' is not supported by the gpsim harness "
     "(boot, rx, tick, sensor, fault sensor|bus|sda, poke)"),
    ("boot\nfault sensor maybe\n", "stimulus line 2: 'fault sensor maybe': only 'fault "
     "sensor', 'fault bus' and 'fault sda' work in gpsim; gpsim 0.31's MSSP master keeps "
     "driving SDA with the last bit of a byte during the ACK clock, so a missing device is "
     "seen as ACKing every byte that ends in 0 (every write address): only read NACKs can "
     "be simulated"),
])
def test_refusals_word_for_word(papaman, stimulus: str, message: str) -> None:
    with pytest.raises(ProtocolError) as info:
        build_script(papaman, stimulus, "fw.cod", "image.hex")
    assert str(info.value) == message
