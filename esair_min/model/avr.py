"""Datasheet arithmetic for the ATmega328P: the tick timer, USART baud, TWI bit rate,
ADC clock and the servo PWM timer.

Pure functions over numbers, like :mod:`esair_min.model.hardware` for the PIC18F452;
:mod:`esair_min.model.mcu` describes the part, the generator only copies these results
into C. Formulas: ATmega328P datasheet (DS40002061), sections 16 (Timer/Counter1),
20.3.1 (USART baud rate), 22.5.2 (TWI bit rate) and 24.4 (ADC prescaler).
"""

from __future__ import annotations

from dataclasses import dataclass

#: Timer/Counter1 clock select (CS12:0) per prescale.
TIMER1_CS = {1: 0b001, 8: 0b010, 64: 0b011, 256: 0b100, 1024: 0b101}


@dataclass(frozen=True)
class Timer1Tick:
    """The tick on Timer1 in CTC mode: an interrupt every prescale * (OCR1A + 1) cycles."""

    prescale: int
    ocr1a: int
    period_s: float

    @property
    def period_ms(self) -> float:
        return self.period_s * 1e3

    @property
    def cycles(self) -> int:
        """CPU cycles per tick."""
        return self.prescale * (self.ocr1a + 1)

    @property
    def tccr1b(self) -> int:
        """WGM12 (CTC on OCR1A) and the clock select."""
        return 0x08 | TIMER1_CS[self.prescale]

    def fields(self) -> str:
        return f"CTC, prescale {self.prescale}, OCR1A {self.ocr1a}"

    def describe(self, clock_hz: int) -> str:
        return f"Timer1 {self.fields()} at {clock_hz} Hz"


def best_timer1_tick(clock_hz: int, period_s: float) -> Timer1Tick:
    """The Timer1 CTC setting nearest ``period_s`` (ties: the smaller prescale)."""
    best: tuple[float, int, int] | None = None
    for pre in TIMER1_CS:
        counts = period_s * clock_hz / pre
        for top in {min(0xFFFF, max(0, int(counts) - 1)), min(0xFFFF, max(0, int(counts)))}:
            err = abs(pre * (top + 1) / clock_hz - period_s)
            key = (round(err, 15), pre, top)
            if best is None or key < best:
                best = key
    assert best is not None
    _, pre, top = best
    return Timer1Tick(pre, top, pre * (top + 1) / clock_hz)


@dataclass(frozen=True)
class UsartBaud:
    u2x: int
    ubrr: int
    actual: float
    error: float        # signed fraction

    @property
    def error_percent(self) -> float:
        return self.error * 100.0

    def describe(self) -> str:
        return f"UBRR0 {self.ubrr} with U2X0={self.u2x}"


def usart_baud(clock_hz: int, u2x: int, ubrr: int) -> float:
    """Asynchronous rate: Fosc / (16 (U2X0=0) or 8 (U2X0=1) * (UBRR0 + 1))."""
    return clock_hz / ((8 if u2x else 16) * (ubrr + 1))


def best_usart_baud(clock_hz: int, baud: int) -> UsartBaud:
    """The UBRR0/U2X0 pair nearest ``baud``; normal speed (U2X0=0) on equal error."""
    best: UsartBaud | None = None
    for u2x in (0, 1):
        ideal = clock_hz / ((8 if u2x else 16) * baud) - 1
        for ubrr in {min(4095, max(0, int(ideal))), min(4095, max(0, int(ideal) + 1))}:
            actual = usart_baud(clock_hz, u2x, ubrr)
            err = (actual - baud) / baud
            if best is None or abs(err) < abs(best.error) - 1e-12:
                best = UsartBaud(u2x, ubrr, actual, err)
    assert best is not None
    return best


@dataclass(frozen=True)
class TwiRate:
    twbr: int
    twps: int           # prescaler bits: 4 ** twps
    actual_hz: float

    @property
    def scl_cycles(self) -> int:
        """CPU cycles per SCL period: 16 + 2 * TWBR * 4^TWPS."""
        return 16 + 2 * self.twbr * 4 ** self.twps

    def describe(self) -> str:
        return f"TWBR {self.twbr} TWPS {self.twps}"


def twi_master_rate(clock_hz: int, speed_hz: int) -> TwiRate | None:
    """The TWI bit rate nearest ``speed_hz`` not above it; None if unreachable (TWBR >= 10
    in master mode, datasheet 22.5.2)."""
    for twps in range(4):
        twbr = -(-(clock_hz // speed_hz - 16) // (2 * 4 ** twps))   # rounded up: not faster
        if 10 <= twbr <= 255:
            return TwiRate(twbr, twps, clock_hz / (16 + 2 * twbr * 4 ** twps))
    return None


#: ADC prescaler (ADPS2:0) per division factor.
ADC_PRESCALES = {2: 1, 4: 2, 8: 3, 16: 4, 32: 5, 64: 6, 128: 7}
ADC_MAX_HZ = 200_000        # full 10-bit resolution needs an ADC clock of 50..200 kHz


@dataclass(frozen=True)
class AdcClock:
    divisor: int
    adps: int

    def conversion_cycles(self) -> int:
        """CPU cycles of one conversion (13 ADC clocks)."""
        return 13 * self.divisor


def adc_clock(clock_hz: int) -> AdcClock | None:
    """The smallest prescaler giving an ADC clock of at most 200 kHz."""
    for div, adps in ADC_PRESCALES.items():
        if clock_hz / div <= ADC_MAX_HZ:
            return AdcClock(div, adps)
    return None


@dataclass(frozen=True)
class ServoTimer:
    """Timer1 (normal mode) for the 50 Hz software PWM: counts = us * num / den."""

    prescale: int
    frame_counts: int
    num: int
    den: int

    @property
    def tccr1b(self) -> int:
        return TIMER1_CS[self.prescale]

    def counts(self, us: int) -> int:
        return us * self.num // self.den


def servo_timer(clock_hz: int, frame_us: int = 20_000) -> ServoTimer | None:
    """The smallest prescale whose 20 ms frame fits 16 bits in whole counts; None if none."""
    from fractions import Fraction
    for pre in (1, 8, 64, 256, 1024):
        per_us = Fraction(clock_hz, pre * 1_000_000)
        frame = frame_us * per_us
        if frame <= 0xFFFF and frame.denominator == 1:
            return ServoTimer(pre, int(frame), per_us.numerator, per_us.denominator)
    return None


#: Timer/Counter2 clock select (CS22:0) per prescale (its own set: datasheet section 18.11).
TIMER2_CS = {1: 0b001, 8: 0b010, 32: 0b011, 64: 0b100, 128: 0b101, 256: 0b110, 1024: 0b111}


@dataclass(frozen=True)
class Timer2Ctc:
    """Timer2 in CTC mode (WGM21): an interrupt every prescale * (OCR2A + 1) cycles."""

    prescale: int
    ocr2a: int

    @property
    def cycles(self) -> int:
        return self.prescale * (self.ocr2a + 1)

    @property
    def tccr2b(self) -> int:
        return TIMER2_CS[self.prescale]


def timer2_ctc(clock_hz: int, rate_hz: int) -> Timer2Ctc | None:
    """The smallest prescale giving exactly ``rate_hz`` interrupts in 8 bits; None if none."""
    if clock_hz % rate_hz:
        return None
    cycles = clock_hz // rate_hz
    for pre in TIMER2_CS:
        if cycles % pre == 0 and cycles // pre <= 256:
            return Timer2Ctc(pre, cycles // pre - 1)
    return None
