"""Computed hardware values against the PIC18FXX2 datasheet formulas (DS39564).

The formulas are written out here on their own, so a slip in esair_min/model/hardware.py
cannot hide behind itself:
  Timer2 period = 4/Fosc * prescale * (PR2 + 1) * postscale      (section 13)
  async baud    = Fosc / (16 * (SPBRG + 1)) with BRGH=1, 64 with BRGH=0 (section 16)
  I2C master    = Fosc / (4 * (SSPADD + 1))                      (section 15.4.7)
"""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from esair_min.model import hardware
from esair_min.model.layout import DIR_ENTRY_BYTES, HEADER_BYTES
from esair_min.model.validate import encode_high, load_robot

ROOT = Path(__file__).resolve().parents[2]


def datasheet_timer2_s(fosc: float, prescale: int, pr2: int, postscale: int) -> float:
    return 4.0 / fosc * prescale * (pr2 + 1) * postscale


def datasheet_baud(fosc: float, brgh: int, spbrg: int) -> float:
    return fosc / ((16 if brgh else 64) * (spbrg + 1))


@pytest.fixture(scope="module")
def papaman():
    return load_robot(ROOT / "boards" / "papaman")


# -- Timer2 -----------------------------------------------------------------------------

def test_thesis_tick_at_20mhz() -> None:
    period = hardware.timer2_period_s(20_000_000, 16, 233, 12)
    assert period == pytest.approx(8.9856e-3, rel=1e-12)
    assert period == pytest.approx(datasheet_timer2_s(20e6, 16, 233, 12), rel=1e-12)


def test_same_setting_at_30mhz_is_about_6ms() -> None:
    period = hardware.timer2_period_s(30_000_000, 16, 233, 12)
    assert period * 1e3 == pytest.approx(5.9904, rel=1e-9)
    assert round(period * 1e3, 2) == 5.99


def test_best_timer2_finds_the_thesis_setting() -> None:
    t2 = hardware.best_timer2(20_000_000, 8.9856e-3)
    assert (t2.prescale, t2.pr2, t2.postscale) == (16, 233, 12)
    assert t2.period_ms == pytest.approx(8.9856, rel=1e-12)
    assert t2.instructions == 16 * 234 * 12 == 44928
    # T2CON: TOUTPS = 12-1 in bits 6:3, TMR2ON bit 2, T2CKPS = 0b10 (1:16) in bits 1:0.
    assert t2.t2con == 0b0_1011_1_10 == 0x5E


def test_papaman_model_exposes_the_tick(papaman) -> None:
    t2 = papaman.central.timer2
    assert (t2.prescale, t2.pr2, t2.postscale) == (16, 233, 12)
    assert f"{t2.period_ms:.4f}" == "8.9856"


@settings(max_examples=60, deadline=None)
@given(clock=st.integers(min_value=1_000_000, max_value=40_000_000),
       period_ms=st.floats(min_value=0.001, max_value=200.0))
def test_best_timer2_is_never_beaten(clock: int, period_ms: float) -> None:
    """No legal (prescale, PR2, postscale) comes closer than best_timer2's choice."""
    want = period_ms / 1e3
    t2 = hardware.best_timer2(clock, want)
    assert t2.prescale in (1, 4, 16) and 0 <= t2.pr2 <= 255 and 1 <= t2.postscale <= 16
    assert t2.period_s == pytest.approx(
        datasheet_timer2_s(clock, t2.prescale, t2.pr2, t2.postscale), rel=1e-12)
    got = abs(t2.period_s - want)
    brute = min(abs(datasheet_timer2_s(clock, pre, pr2, post) - want)
                for pre in (1, 4, 16) for post in range(1, 17) for pr2 in range(256))
    assert got <= brute + 1e-12 * want


# -- USART baud -------------------------------------------------------------------------

def test_9600_baud_at_20mhz() -> None:
    b = hardware.best_baud(20_000_000, 9600)
    assert (b.brgh, b.spbrg) == (1, 129)
    assert b.actual == pytest.approx(datasheet_baud(20e6, 1, 129)) == pytest.approx(9615.38, abs=0.01)
    assert f"{b.error_percent:+.2f}" == "+0.16"


def test_papaman_model_exposes_the_baud(papaman) -> None:
    b = papaman.central.baud
    assert (b.brgh, b.spbrg, f"{b.error_percent:+.2f}") == (1, 129, "+0.16")


@settings(max_examples=60, deadline=None)
@given(clock=st.integers(min_value=1_000_000, max_value=40_000_000),
       baud=st.integers(min_value=300, max_value=1_000_000))
def test_best_baud_is_never_beaten(clock: int, baud: int) -> None:
    b = hardware.best_baud(clock, baud)
    assert b.actual == pytest.approx(datasheet_baud(clock, b.brgh, b.spbrg))
    brute = min(abs(datasheet_baud(clock, brgh, spbrg) - baud)
                for brgh in (0, 1) for spbrg in range(256))
    assert abs(b.actual - baud) <= brute + 1e-9 * baud


# -- MSSP I2C ---------------------------------------------------------------------------

def test_i2c_100khz_at_20mhz() -> None:
    s = hardware.i2c_master_setting(20_000_000, 100_000)
    assert s is not None and s.sspadd == 49
    assert s.actual_hz == 20e6 / (4 * (49 + 1)) == 100_000


def test_i2c_400khz_at_20mhz() -> None:
    s = hardware.i2c_master_setting(20_000_000, 400_000)
    assert s is not None and s.sspadd == 11
    assert s.actual_hz == pytest.approx(416_666.67, abs=0.01)


def test_i2c_unreachable_rate() -> None:
    # 1 MHz / (4 * 400 kHz) - 1 rounds to 0: SSPADD must be 1..127.
    assert hardware.i2c_master_setting(1_000_000, 400_000) is None


def test_papaman_model_exposes_sspadd(papaman) -> None:
    assert papaman.central.i2c_setting.sspadd == 49


# -- EEPROM layout and encoding ---------------------------------------------------------

def test_papaman_eeprom_layout(papaman) -> None:
    layout = papaman.layout
    frames = {"stand": 1, "sit": 3, "prostrate": 4, "dance": 32, "balance": 3}
    assert [(s.number, s.name, s.frames) for s in layout.slots] == [
        (0, "stand", 1), (1, "sit", 3), (2, "prostrate", 4), (3, "dance", 32),
        (4, "balance", 3)]
    assert layout.frame_bytes == 24
    # Header 8 bytes, 5 directory entries of 6, then 43 frames of 24 bytes.
    assert HEADER_BYTES == 8 and DIR_ENTRY_BYTES == 6
    assert layout.total_bytes == 8 + 6 * 5 + sum(frames.values()) * 24 == 1070
    offsets = [s.offset for s in layout.slots]
    assert offsets == [38, 38 + 24, 38 + 4 * 24, 38 + 8 * 24, 38 + 40 * 24]
    assert papaman.eeprom.size_bytes == 32768


@pytest.mark.parametrize("angle, speed, high", [
    (90, 0, 0), (90, 2, 20), (180, 5, 51), (999, 24, 249), (599, 25, 255), (600, 25, 256),
])
def test_thesis_high_byte(angle: int, speed: int, high: int) -> None:
    assert encode_high(angle, speed) == high


def test_frame_bus_load_in_bit_times():
    # PAPA-MAN: 12 servos, 2-byte EEPROM addresses, 16 sensor registers
    load = hardware.tick_bus_load(12, 2, 16)
    assert (load.write, load.read, load.poll) == (236, 255, 174)
    assert load.seconds(100_000) == pytest.approx(6.65e-3)
    assert hardware.tick_bus_load(12, 2, 0).bits == 236 + 255     # no reactions: no poll
    # 1 servo: START + address + pointer + 2 bytes + STOP; reads: pointer/address byte,
    # repeated START, address, 2 bytes
    one = hardware.tick_bus_load(1, 1, 2)
    assert (one.write, one.read, one.poll) == (1 + 9 + 27 + 1, 1 + 9 + 9 + 1 + 9 + 18 + 1,
                                               1 + 9 + 9 + 1 + 9 + 18 + 1)

