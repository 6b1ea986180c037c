"""STARFISH's gpsim stimulus lines (esair_min/pic/starfish_gpsim.py, one function a verb,
as the PAPA-MAN harnesses: tests/min/test_gpsim_stimulus.py): each verb's gpsim commands
and each refusal word for word. Only the command file is built here (no gpsim run:
tests/min/test_starfish_gpsim.py runs them)."""

from __future__ import annotations

import pytest

from esair_min.errors import ProtocolError
from esair_min.pic.starfish_gpsim import BOOT_CYCLES, DRAIN_TICKS, Setup, gpsim_script

EPILOGUE = 11         # the drain's break and run, log off, 6 recorders closed, cycles, quit


@pytest.fixture(scope="module")
def setup(starfish):
    return Setup.from_robot(starfish)


def commands(setup, stimulus: str) -> tuple[list[str], list[tuple[int, int, int]]]:
    """The command lines the stimulus adds after the setup and before the epilogue."""
    bare, _ = gpsim_script(setup, "", "fw.cod")
    full, floors = gpsim_script(setup, stimulus, "fw.cod")
    head, tail = bare.splitlines(), full.splitlines()
    cut = len(head) - EPILOGUE
    assert tail[:cut] == head[:cut] and tail[-EPILOGUE + 2:] == head[-EPILOGUE + 2:]
    return tail[cut:-EPILOGUE], floors


def test_each_verb_writes_its_gpsim_commands(setup):
    tick = setup.tick_cycles
    assert setup.tick_cycles == 49952 and BOOT_CYCLES == 40_000
    assert commands(setup, "rx V+0 1\n") == (
        [f"U1.tx = {b:#04x}" for b in b"V+0 1\r\n"], [])
    assert commands(setup, "raw 41 0d # a comment\n# only a comment\n\n") == (
        ["U1.tx = 0x41", "U1.tx = 0x0d"], [])
    assert commands(setup, "tick 2\n") == ([f"break c {BOOT_CYCLES + 2 * tick}", "run"], [])
    assert commands(setup, "tick 1\nfloor 1 1\nfloor 0 0\n") == (
        [f"break c {BOOT_CYCLES + tick}", "run", "PF1.voltage = 5.0", "PF0.voltage = 0.0"],
        [(BOOT_CYCLES + tick, 1, 1), (BOOT_CYCLES + tick, 0, 0)])
    # the drain: the end cycle follows the stimulus's ticks
    full, _ = gpsim_script(setup, "tick 3\n", "fw.cod")
    assert f"break c {BOOT_CYCLES + (3 + DRAIN_TICKS) * tick}" in full.splitlines()


@pytest.mark.parametrize("stimulus, message", [
    ("foo\n", "stimulus line 1: 'foo' is not rx TEXT, raw HH ..., tick N or floor S 0|1"),
    ("tick 1\ntick 0\n",
     "stimulus line 2: 'tick 0' is not rx TEXT, raw HH ..., tick N or floor S 0|1"),
    ("tick x\n", "stimulus line 1: 'tick x' is not rx TEXT, raw HH ..., tick N or floor S 0|1"),
    ("tick 1 2\n",
     "stimulus line 1: 'tick 1 2' is not rx TEXT, raw HH ..., tick N or floor S 0|1"),
    ("raw\n", "stimulus line 1: 'raw' is not rx TEXT, raw HH ..., tick N or floor S 0|1"),
    ("raw zz\n", "stimulus line 1: 'raw zz' is not rx TEXT, raw HH ..., tick N or floor S 0|1"),
    ("floor 0 2\n",
     "stimulus line 1: 'floor 0 2' is not rx TEXT, raw HH ..., tick N or floor S 0|1"),
    ("floor x 1\n",
     "stimulus line 1: 'floor x 1' is not rx TEXT, raw HH ..., tick N or floor S 0|1"),
    ("floor 2 1\n", "floor 2: there are 2 flow sensors"),
])
def test_refusals_word_for_word(setup, stimulus: str, message: str) -> None:
    with pytest.raises(ProtocolError) as info:
        gpsim_script(setup, stimulus, "fw.cod")
    assert str(info.value) == message
