"""What each supported MCU has: memories, clock, timers, PWM units, UART, I2C, ADC, pins.

One :class:`McuSpec` per ``mcu.part``; the validator checks a board against its part
(a pin it lacks, a baud rate or tick it cannot make, more analog channels than it has)
and the generator picks the port folder ``ports/<part>/``. Timer, baud and bus numbers
come from :mod:`esair_min.model.hardware` (PIC18F452) and :mod:`esair_min.model.avr`
(ATmega328P).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from esair_min.model import avr, hardware


@dataclass(frozen=True)
class BusOverhead:
    """What an I2C transfer of the generated master costs beyond its wire bits, in the
    MCU's instruction cycles: a fixed part (write; write + repeated START + read) and a
    part per byte written (address byte excluded: register/memory address and data) and
    per byte read. Least-squares fits to the START..STOP durations measured for every
    transfer kind of tests/fixtures/gpsim/papaman.txt: PIC18F452 in gpsim (wire), ATmega328P
    in the simavr driver (TWSTA write to TWSTO write); bench/avr_vs_pic.py prints the fit and
    each kind's error (all within 0.4 %; wire time alone is 7-10 % short on the PIC)."""

    write_fixed: float
    read_fixed: float
    per_write_byte: float
    per_read_byte: float

    def cycles(self, n_write: int, n_read: int | None) -> float:
        """``n_read`` None: a plain write."""
        if n_read is None:
            return self.write_fixed + self.per_write_byte * n_write
        return self.read_fixed + self.per_write_byte * n_write + self.per_read_byte * n_read


@dataclass(frozen=True)
class McuSpec:
    part: str
    family: str                    # "pic18" or "avr"
    name: str                      # as a datasheet writes it
    flash_bytes: int
    ram_bytes: int
    eeprom_bytes: int
    max_clock_hz: int
    timers: tuple[str, ...]
    pwm_units: tuple[str, ...]     # hardware PWM outputs (the ports use software PWM)
    twi_master: bool
    twi_slave: bool
    pins: tuple[str, ...]          # general-purpose pins, by their board-file names
    pin_help: str
    uart_pins: tuple[str, ...]     # taken when the board has a UART
    i2c_pins: tuple[str, ...]      # taken by the I2C/TWI port
    adc_pins: dict[int, str]       # analog channel -> pin
    sync_input: str                # the actuator's latch input (an edge-flagging pin)
    tick_timer: str
    bus_overhead: BusOverhead      # the generated I2C master's cost beyond the wire
    #: package -> what it is; the first is the default (``mcu.package`` omitted)
    packages: dict[str, str] = field(default_factory=dict)
    #: package -> the analog channels it has no pin for
    package_lacks: dict[str, tuple[int, ...]] = field(default_factory=dict)
    package: str = ""              # the package this spec describes ("" = any)
    #: the hardware PWM outputs the drive board's port drives a motor with: unit -> pin
    drive_pwm: dict[str, str] = field(default_factory=dict)
    #: hardware PWM outputs the drive board's port takes for something else: unit -> (pin, why)
    drive_pwm_taken: dict[str, tuple[str, str]] = field(default_factory=dict)

    @property
    def adc_channels(self) -> tuple[int, ...]:
        return tuple(sorted(self.adc_pins))

    @property
    def default_package(self) -> str:
        return next(iter(self.packages))

    def in_package(self, package: str | None) -> McuSpec:
        """This part in ``package`` (None: the default one): the analog channels the
        package has no pin for removed. ``package`` must be one of ``packages``."""
        package = package or self.default_package
        lacks = self.package_lacks.get(package, ())
        return replace(self, package=package,
                       adc_pins={ch: pin for ch, pin in self.adc_pins.items() if ch not in lacks})

    def packages_with_channel(self, channel: int) -> tuple[str, ...]:
        """The packages of this part that have analog channel ``channel``."""
        if channel not in self.adc_pins:
            return ()
        return tuple(p for p in self.packages if channel not in self.package_lacks.get(p, ()))


PIC18F452 = McuSpec(
    part="pic18f452", family="pic18", name="PIC18F452",
    flash_bytes=32768, ram_bytes=1536, eeprom_bytes=256, max_clock_hz=40_000_000,
    timers=("Timer0", "Timer1", "Timer2", "Timer3"), pwm_units=("CCP1", "CCP2"),
    twi_master=True, twi_slave=True, pins=hardware.ALL_PINS,
    pin_help="RA0..RA5, RB0..RB7, RC0..RC7, RD0..RD7, RE0..RE2",
    uart_pins=hardware.UART_PINS, i2c_pins=hardware.I2C_PINS, adc_pins=hardware.ADC_PINS,
    sync_input="RB0", tick_timer="Timer2",
    bus_overhead=BusOverhead(52.1, 206.9, 32.8, 41.5),
    packages={"dip": "40-pin PDIP", "plcc": "44-pin PLCC", "tqfp": "44-pin TQFP"},
    drive_pwm={"ccp1": "RC2", "ccp2": "RC1"})

#: ADC6/ADC7 are analog-only pins of the 32-pin TQFP and 32-pad QFN/MLF packages
#: (Arduino Nano, Pro Mini); the 28-pin PDIP (Arduino Uno) has no pin for them
#: (datasheet DS40002061, section 5: pin configurations).
ATMEGA328P = McuSpec(
    part="atmega328p", family="avr", name="ATmega328P",
    flash_bytes=32768, ram_bytes=2048, eeprom_bytes=1024, max_clock_hz=20_000_000,
    timers=("Timer0", "Timer1", "Timer2"),
    pwm_units=("OC0A", "OC0B", "OC1A", "OC1B", "OC2A", "OC2B"),
    twi_master=True, twi_slave=True,
    pins=tuple(f"PB{i}" for i in range(6)) + tuple(f"PC{i}" for i in range(6))
    + tuple(f"PD{i}" for i in range(8)),
    pin_help="PB0..PB5, PC0..PC5, PD0..PD7 (PB6/PB7 hold the crystal)",
    uart_pins=("PD0", "PD1"), i2c_pins=("PC4", "PC5"),
    adc_pins={0: "PC0", 1: "PC1", 2: "PC2", 3: "PC3", 4: "PC4", 5: "PC5", 6: "ADC6",
              7: "ADC7"},
    sync_input="PD2", tick_timer="Timer1",
    bus_overhead=BusOverhead(-100.7, -11.7, 38.1, 25.3),
    packages={"dip": "28-pin PDIP (Arduino Uno)", "tqfp": "32-pin TQFP (Arduino Nano, Pro Mini)",
              "qfn": "32-pad QFN/MLF"},
    package_lacks={"dip": (6, 7)},
    # The drive port: Timer0 and Timer1 in 8-bit phase-correct PWM (31.4 kHz at 16 MHz),
    # Timer2 its 10 kHz interrupt (software PWM, control tick): datasheet sections 15-18.
    drive_pwm={"oc0a": "PD6", "oc0b": "PD5", "oc1a": "PB1", "oc1b": "PB2"},
    drive_pwm_taken={"oc2a": ("PB3", "Timer2"), "oc2b": ("PD3", "Timer2")})

MCUS: dict[str, McuSpec] = {m.part: m for m in (PIC18F452, ATMEGA328P)}


#: Every package name any part has (the board schema's choices).
PACKAGES: tuple[str, ...] = tuple(dict.fromkeys(p for m in MCUS.values() for p in m.packages))


def spec(part: str, package: str | None = None) -> McuSpec:
    """The part in ``package`` (None: its default package); a package the part does
    not come in gives its default package (the validator reports the package)."""
    m = MCUS[part]
    return m.in_package(package if package in m.packages else None)


def tick_setting(part: str, clock_hz: int, period_s: float):
    """The tick timer's setting: hardware.Timer2Setting (PIC) or avr.Timer1Tick."""
    if MCUS[part].family == "avr":
        return avr.best_timer1_tick(clock_hz, period_s)
    return hardware.best_timer2(clock_hz, period_s)


def baud_setting(part: str, clock_hz: int, baud: int):
    """hardware.BaudSetting (PIC: SPBRG/BRGH) or avr.UsartBaud (UBRR0/U2X0)."""
    if MCUS[part].family == "avr":
        return avr.best_usart_baud(clock_hz, baud)
    return hardware.best_baud(clock_hz, baud)


def i2c_master_setting(part: str, clock_hz: int, speed_hz: int):
    """hardware.I2cSetting (PIC: SSPADD) or avr.TwiRate (TWBR/TWPS); None if unreachable."""
    if MCUS[part].family == "avr":
        return avr.twi_master_rate(clock_hz, speed_hz)
    return hardware.i2c_master_setting(clock_hz, speed_hz)


def cycles_per_second(part: str, clock_hz: int) -> int:
    """Instruction cycles per second: Fosc/4 on the PIC, Fosc on the AVR."""
    return clock_hz if MCUS[part].family == "avr" else clock_hz // 4


def bus_overhead_ns(part: str, clock_hz: int, n_write: int, n_read: int | None) -> int:
    """The master's overhead of one transfer in ns (see BusOverhead)."""
    cycles = MCUS[part].bus_overhead.cycles(n_write, n_read)
    return int(round(cycles * 1e9 / cycles_per_second(part, clock_hz)))
