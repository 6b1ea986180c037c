"""Port numbers that esair_min.model.hardware does not compute: software PWM timing (Timer1),
the ADC conversion clock, the oscillator config and the I2C slave address register.

Pure functions of the model's numbers; the templates only copy the results.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

from esair_min.errors import GenerateError

PWM_PERIOD_US = 20_000          # 50 Hz servo frame
TIMER1_PRESCALES = (1, 2, 4, 8)
T1CKPS = {1: 0b00, 2: 0b01, 4: 0b10, 8: 0b11}
ADC_TAD_MIN_S = 1.6e-6          # PIC18FXX2 datasheet, table 22-? (minimum Tad)
#: ADC clock divisor -> (ADCS2 in ADCON1<6>, ADCS1:ADCS0 in ADCON0<7:6>)
ADC_DIVISORS = {2: (0, 0b00), 4: (1, 0b00), 8: (0, 0b01), 16: (1, 0b01), 32: (0, 0b10),
                64: (1, 0b10)}


@dataclass(frozen=True)
class PwmTiming:
    prescale: int
    t1con: int              # TMR1ON, 16-bit read/write, prescale bits
    frame_counts: int       # Timer1 counts in one 20 ms frame
    num: int                # counts = us * num / den
    den: int

    def counts(self, us: int) -> int:
        return us * self.num // self.den


def pwm_timing(clock_hz: int) -> PwmTiming:
    """Timer1 at Fosc/4 with the smallest prescale that holds a 20 ms frame in 16 bits."""
    for pre in TIMER1_PRESCALES:
        per_us = Fraction(clock_hz, 4 * pre * 1_000_000)
        frame = PWM_PERIOD_US * per_us
        if frame <= 0xFFFF:
            if frame.denominator != 1:
                raise GenerateError(f"a {clock_hz} Hz clock gives no whole number of Timer1 "
                                    f"counts in a 20 ms PWM frame")
            t1con = 0x80 | (T1CKPS[pre] << 4) | 0x01    # RD16, T1CKPS, TMR1ON
            return PwmTiming(pre, t1con, int(frame), per_us.numerator, per_us.denominator)
    raise GenerateError(f"a {clock_hz} Hz clock is too fast for a 20 ms PWM frame "
                        f"on Timer1")


@dataclass(frozen=True)
class AdcClock:
    divisor: int
    adcs2: int
    adcs: int


def adc_clock(clock_hz: int) -> AdcClock:
    """The smallest conversion clock divisor giving Tad >= 1.6 us."""
    for div in sorted(ADC_DIVISORS):
        if div / clock_hz >= ADC_TAD_MIN_S - 1e-15:
            adcs2, adcs = ADC_DIVISORS[div]
            return AdcClock(div, adcs2, adcs)
    raise GenerateError(f"a {clock_hz} Hz clock is too fast for the ADC (Tad >= 1.6 us)")


def oscillator(clock_hz: int) -> str:
    """The OSC config setting: XT up to 4 MHz, HS to 25 MHz, EC (external clock) above."""
    if clock_hz <= 4_000_000:
        return "XT"
    if clock_hz <= 25_000_000:
        return "HS"
    return "EC"
