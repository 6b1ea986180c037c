"""Datasheet arithmetic for PIC18F452-class parts: Timer2, USART baud, MSSP I2C.

Pure functions over numbers; the validator calls them and stores the results in the
model, the generator only copies them into C. Formulas: PIC18FXX2 datasheet
(DS39564), sections 13 (Timer2), 16 (USART baud rate generator) and 15.4.7 (MSSP
baud rate generator).
"""

from __future__ import annotations

from dataclasses import dataclass

TIMER2_PRESCALES = (1, 4, 16)
TIMER2_POSTSCALES = tuple(range(1, 17))


@dataclass(frozen=True)
class Timer2Setting:
    prescale: int
    pr2: int
    postscale: int
    period_s: float

    @property
    def period_ms(self) -> float:
        return self.period_s * 1e3

    @property
    def t2con(self) -> int:
        """T2CON value with TMR2ON set (bits: TOUTPS3:0 <6:3>, TMR2ON <2>, T2CKPS <1:0>)."""
        ckps = {1: 0b00, 4: 0b01, 16: 0b10}[self.prescale]
        return ((self.postscale - 1) << 3) | 0b100 | ckps

    @property
    def instructions(self) -> int:
        """Instruction cycles per tick."""
        return self.prescale * (self.pr2 + 1) * self.postscale

    def fields(self) -> str:
        return f"prescale {self.prescale}, PR2 {self.pr2}, postscale {self.postscale}"

    def describe(self, clock_hz: int) -> str:
        return f"Timer2 {self.fields()} at {clock_hz} Hz"


def timer2_period_s(clock_hz: int, prescale: int, pr2: int, postscale: int) -> float:
    """Period of the Timer2 interrupt: 4/Fosc * prescale * (PR2+1) * postscale."""
    return 4.0 / clock_hz * prescale * (pr2 + 1) * postscale


def best_timer2(clock_hz: int, period_s: float) -> Timer2Setting:
    """The Timer2 setting nearest ``period_s``.

    Ties go to the larger prescale, then the larger PR2 (finer later adjustment), so
    20 MHz and 8.9856 ms give the thesis's prescale 16, PR2 233, postscale 12.
    """
    best: tuple[float, int, int, int] | None = None
    for pre in TIMER2_PRESCALES:
        for post in TIMER2_POSTSCALES:
            counts = period_s * clock_hz / 4.0 / pre / post
            for pr2 in {min(255, max(0, int(counts) - 1)), min(255, max(0, int(counts)))}:
                err = abs(timer2_period_s(clock_hz, pre, pr2, post) - period_s)
                key = (round(err, 15), -pre, -pr2, post)
                if best is None or key < best:
                    best = key
    assert best is not None
    _, npre, npr2, post = best
    pre, pr2 = -npre, -npr2
    return Timer2Setting(pre, pr2, post, timer2_period_s(clock_hz, pre, pr2, post))


@dataclass(frozen=True)
class BaudSetting:
    brgh: int
    spbrg: int
    actual: float
    error: float  # signed fraction: +0.0016 means 0.16 % fast

    @property
    def error_percent(self) -> float:
        return self.error * 100.0

    def describe(self) -> str:
        return f"SPBRG {self.spbrg} with BRGH={self.brgh}"


def baud_rate(clock_hz: int, brgh: int, spbrg: int) -> float:
    """Asynchronous USART rate: Fosc / (16 (BRGH=1) or 64 (BRGH=0) * (SPBRG + 1))."""
    return clock_hz / ((16 if brgh else 64) * (spbrg + 1))


def best_baud(clock_hz: int, baud: int) -> BaudSetting:
    """The SPBRG/BRGH pair nearest ``baud``; BRGH=1 preferred on equal error."""
    best: BaudSetting | None = None
    for brgh in (1, 0):
        ideal = clock_hz / ((16 if brgh else 64) * baud) - 1
        for spbrg in {min(255, max(0, int(ideal))), min(255, max(0, int(ideal) + 1))}:
            actual = baud_rate(clock_hz, brgh, spbrg)
            err = (actual - baud) / baud
            if best is None or abs(err) < abs(best.error) - 1e-12:
                best = BaudSetting(brgh, spbrg, actual, err)
    assert best is not None
    return best


@dataclass(frozen=True)
class I2cSetting:
    sspadd: int
    actual_hz: float

    def describe(self) -> str:
        return f"SSPADD {self.sspadd}"


def i2c_master_setting(clock_hz: int, speed_hz: int) -> I2cSetting | None:
    """MSSP master rate: Fosc / (4 * (SSPADD + 1)), SSPADD 7 bits; None if unreachable."""
    sspadd = round(clock_hz / (4 * speed_hz)) - 1
    if not 1 <= sspadd <= 127:
        return None
    return I2cSetting(sspadd, clock_hz / (4 * (sspadd + 1)))


# -- I2C bus time -------------------------------------------------------------------
#: Bit times of the parts of a transaction: START, STOP, repeated START; a byte with
#: its ACK/NACK clock.
START = STOP = RESTART = 1
BYTE = 9
#: The PIC port's MSSP master takes 1.09x (frame write) and 1.13x (frame read) the
#: wire time in gpsim (docs/toolchain.md); bus budgets allow this much.
FIRMWARE_BUS_OVERHEAD = 1.15
#: A transfer on a stuck bus (SCL or SDA held low) on the PIC port's MSSP master: the
#: SSPIF countdown runs out, then bus_recover resets the MSSP and clears the bus (nine
#: SCL pulses, STOP); instruction cycles measured in gpsim (docs/toolchain.md).
I2C_TIMEOUT_CYCLES = 8_200
I2C_BUS_CLEAR_CYCLES = 725
#: The bus speed the generated I2C slave firmware (actuator, sensor) is verified at. It
#: takes every byte at 400 kHz too in gpsim, but there a byte it takes late, after the
#: master's next START, could be mistaken for its address (docs/toolchain.md).
SLAVE_SPEED_HZ = 100_000


def write_bits(n_data: int) -> int:
    """Bit times of a write of ``n_data`` bytes (register/memory address included)."""
    return START + BYTE + BYTE * n_data + STOP


def write_read_bits(n_write: int, n_read: int) -> int:
    """Bit times of a write of ``n_write`` bytes, repeated start, read of ``n_read``."""
    return START + BYTE + BYTE * n_write + RESTART + BYTE + BYTE * n_read + STOP


def nack_bits() -> int:
    """Bit times of a transaction whose address byte is not acknowledged."""
    return START + BYTE + STOP


@dataclass(frozen=True)
class TickBusLoad:
    """The most I2C work one tick can hold while a motion plays a frame every tick:
    the frame write (register pointer + 2 bytes per servo), the read of the next frame
    from the EEPROM, and a sensor poll (0 without reactions), in bit times."""

    write: int
    read: int
    poll: int

    @property
    def bits(self) -> int:
        return self.write + self.read + self.poll

    def seconds(self, speed_hz: int) -> float:
        return self.bits / speed_hz


def tick_bus_load(servos: int, eeprom_address_bytes: int, sensor_registers: int) -> TickBusLoad:
    return TickBusLoad(write_bits(1 + 2 * servos),
                       write_read_bits(eeprom_address_bytes, 2 * servos),
                       write_read_bits(1, sensor_registers) if sensor_registers else 0)


#: Analog channels of the PIC18F452 and the pins they share.
ADC_PINS = {0: "RA0", 1: "RA1", 2: "RA2", 3: "RA3", 4: "RA5", 5: "RE0", 6: "RE1", 7: "RE2"}
#: Pins taken by the on-chip peripherals when they are enabled.
UART_PINS = ("RC6", "RC7")
I2C_PINS = ("RC3", "RC4")
#: General-purpose pins of the 40-pin package.
PORT_PINS = {
    "A": range(0, 6), "B": range(0, 8), "C": range(0, 8), "D": range(0, 8), "E": range(0, 3),
}
ALL_PINS = tuple(f"R{port}{bit}" for port, bits in PORT_PINS.items() for bit in bits)
