"""The board model: one frozen description of a robot, read by everything else.

These classes are the single definition of the board file format: the validator
builds them from YAML, ``esair schema`` prints their JSON Schema, the generator and
the emulator read them. Rules that involve more than one field or more than one
board live in :mod:`esair_min.model.validate`; values derived from the datasheet live in
:mod:`esair_min.model.hardware` and are exposed here as properties.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Any, Literal, Union

from pydantic import Field, StrictBool, StrictInt, StrictStr, create_model

from esair_min.components import COMPONENTS
# The kinds' schemas and the shared types, re-exported: the board model is where
# readers import them from.
from esair_min.components.motion import MAX_FRAMES, MAX_MOTIONS, Frame, Motion  # noqa: F401
from esair_min.components.pressure_sensor import MAX_SENSORS, Sensor  # noqa: F401
from esair_min.components.servo import MAX_SERVOS, Servo  # noqa: F401
from esair_min.model import avr, hardware, mcu
from esair_min.model.figure import Figure
from esair_min.model.mcu import McuSpec
from esair_min.model.types import (Angle, I2cAddress, Name, Number, Pin,  # noqa: F401
                                   Section, Speed)

class Mcu(Section):
    """The microcontroller and its oscillator."""

    part: Literal["pic18f452", "atmega328p"] = Field(
        "pic18f452", description="MCU part: pic18f452 or atmega328p (esair_min.model.mcu)")
    package: Literal["dip", "tqfp", "qfn", "plcc"] | None = Field(
        None, description="the part's package; omitted = its DIP (the ATmega328P's ADC6/ADC7 "
        "exist in tqfp and qfn only)")
    clock_hz: Annotated[StrictInt, Field(ge=1_000_000, le=40_000_000)] = Field(
        20_000_000, description="oscillator frequency Fosc in Hz")


class Uart(Section):
    """The serial link to the PC (thesis: wireless RS-232)."""

    baud: Annotated[StrictInt, Field(ge=300, le=1_000_000)] = Field(
        9600, description="bits per second, 8N1")
    require_checksum: StrictBool = Field(
        False, description="refuse command lines without a valid *HH checksum suffix")


class Tick(Section):
    """The Timer2 tick that paces the superloop and drives the sync pin."""

    period_ms: Annotated[Number, Field(gt=0)] = Field(
        8.9856, description="wanted tick period in ms (Timer2 must make it within 1 %)")


class Sync(Section):
    """The motor-sync line: an output on the central board, the latch input on the actuator."""

    pin: Pin = Field("RB0", description="pin carrying the sync signal")


class EepromDevice(Section):
    """A serial EEPROM (24LC256 class) holding the motion image."""

    kind: Literal["eeprom"]
    name: Name
    address: I2cAddress = Field(0x50, description="7-bit I2C address")
    size_bytes: Annotated[StrictInt, Field(ge=128, le=131072)] = Field(
        32768, description="capacity in bytes")
    address_bytes: Literal[1, 2] = Field(2, description="width of the memory address")
    page_bytes: Annotated[StrictInt, Field(ge=1, le=256)] = Field(
        64, description="write page size in bytes")


class BoardDevice(Section):
    """A peer board reached over I2C as memory-mapped registers."""

    kind: Literal["board"]
    name: Name
    board: Name = Field(description="the peer's `board:` name")
    address: I2cAddress
    registers: Annotated[StrictInt, Field(ge=1, le=256)] = Field(
        description="size of the peer's register map, bytes")


Device = Annotated[Union[EepromDevice, BoardDevice], Field(discriminator="kind")]


class I2c(Section):
    """The I2C (MSSP) port: master on the central board, slave on peers."""

    mode: Literal["master", "slave"]
    speed_hz: Literal[100_000, 400_000] = Field(100_000, description="bus clock")
    address: I2cAddress | None = Field(None, description="own address (slave only)")
    devices: tuple[Device, ...] = Field((), description="what a master talks to")


Action = Literal["stand", "motor", "play", "speeds", "angles", "version", "sensors", "stop",
                 "image_write", "image_read", "image_commit", "i2c_scan", "hold"]

#: Characters of arguments each action takes after its prefix, per servo count N:
#: ``speeds`` takes 3 digits per servo and ``angles`` one code per servo
#: (36 and 12 on the 12-servo PAPA-MAN, the lengths of the thesis).
ACTION_ARGS: dict[str, tuple[int, int]] = {   # (fixed, per servo)
    "stand": (0, 0), "motor": (5, 0), "play": (2, 0), "speeds": (0, 3), "angles": (0, 1),
    "version": (0, 0), "sensors": (0, 0), "stop": (0, 0),
    # image_write: address (4 hex), at least one data byte (2 hex), checksum (2 hex);
    # its lines have any length from that on (the only variable-length action)
    "image_write": (8, 0), "image_read": (6, 0), "image_commit": (0, 0), "i2c_scan": (0, 0),
    # hold: one digit, 1 holds the firmware's reactions, 0 releases them
    "hold": (1, 0),
}
#: Actions whose lines may be longer than their arguments' minimum (more data bytes).
VARIABLE_ACTIONS = frozenset({"image_write"})


class Command(Section):
    """One row of the PC command table: a line matches when it starts with ``prefix``
    and has exactly ``length`` characters (checksum suffix excluded)."""

    name: Name
    prefix: Annotated[StrictStr, Field(pattern=r"^[!-)+-~]{1,8}$",
                                       description="printable ASCII, no space or '*'")]
    action: Action
    motion: Name | None = Field(None, description="for action play: a fixed motion, no digits")

    def arg_chars(self, servos: int) -> int:
        """Argument characters after the prefix on a robot with ``servos`` servos."""
        if self.action == "play" and self.motion is not None:
            return 0
        fixed, per_servo = ACTION_ARGS[self.action]
        return fixed + per_servo * servos

    def length(self, servos: int) -> int:
        """Characters of a matching line, checksum suffix excluded (the shortest, for a
        variable-length action)."""
        return len(self.prefix) + self.arg_chars(servos)

    @property
    def variable(self) -> bool:
        """Lines of any length from :meth:`length` on match (``image_write``)."""
        return self.action in VARIABLE_ACTIONS


class Reaction(Section):
    """Auto-balance: compare two sensor groups, play a motion when they disagree."""

    name: Name
    kind: Literal["balance"]
    compare: tuple[Name, Name] = Field(description="the two sensor groups compared")
    threshold: Annotated[StrictInt, Field(ge=1, le=65535)] = Field(
        description="|sum(a) - sum(b)| above this counts as tipping, ADC counts")
    samples: Annotated[StrictInt, Field(ge=1, le=255)] = Field(
        3, description="consecutive tipping samples before the reaction fires")
    poll_ticks: Annotated[StrictInt, Field(ge=1, le=255)] = Field(
        5, description="ticks between sensor polls")
    motion: Name = Field(description="motion played when it fires (pre-empts others)")


Role = Literal["central", "actuator", "sensor", "drive"]


class BoardCore(Section):
    """The sections every board may have and the central board's command table and
    reactions; :class:`Board` adds one section per device kind."""

    board: Name = Field(description="the board's name, used by its peers")
    role: Role
    description: StrictStr = ""
    mcu: Mcu = Mcu()
    uart: Uart | None = None
    tick: Tick | None = None
    sync: Sync | None = None
    i2c: I2c
    commands: tuple[Command, ...] | None = Field(
        None, description="PC command table; omitted = the PAPA-MAN table")
    reactions: tuple[Reaction, ...] = ()
    figure: Figure | None = Field(
        None, description="optional: how the HMI draws the robot (actuator boards; a biped "
                          "stick figure from link lengths and joint servos)")

    # Values computed from the datasheet formulas (validated to be in range).
    @property
    def spec(self) -> McuSpec:
        """What this board's MCU has (esair_min.model.mcu)."""
        return mcu.spec(self.mcu.part, self.mcu.package)

    @property
    def timer2(self) -> hardware.Timer2Setting | avr.Timer1Tick | None:
        """The tick timer's setting (Timer2 on the PIC, Timer1 CTC on the AVR): both
        have ``period_s``, ``period_ms`` and ``describe(clock_hz)``."""
        if self.tick is None:
            return None
        return mcu.tick_setting(self.mcu.part, self.mcu.clock_hz, self.tick.period_ms / 1e3)

    @property
    def baud(self) -> hardware.BaudSetting | avr.UsartBaud | None:
        if self.uart is None:
            return None
        return mcu.baud_setting(self.mcu.part, self.mcu.clock_hz, self.uart.baud)

    @property
    def i2c_setting(self) -> hardware.I2cSetting | avr.TwiRate | None:
        if self.i2c.mode != "master":
            return None
        return mcu.i2c_master_setting(self.mcu.part, self.mcu.clock_hz, self.i2c.speed_hz)

    @property
    def register_count(self) -> int:
        """Size of this board's register map as an I2C slave."""
        return sum(c.registers_per_item * len(c.items(self)) for c in COMPONENTS)

    def device(self, kind: str) -> EepromDevice | BoardDevice | None:
        return next((d for d in self.i2c.devices if d.kind == kind), None)


def _component_sections() -> dict[str, Any]:
    return {c.section: ((tuple[c.schema, ...],  # type: ignore[name-defined]  # built at run time
                         Field((), description=c.description)) if c.many
                        else (c.schema | None, Field(None, description=c.description)))
            for c in COMPONENTS}


if TYPE_CHECKING:
    from esair_min.components.analog_mux import Mux
    from esair_min.components.dc_motor import DcMotor
    from esair_min.components.omni_base import OmniBase
    from esair_min.components.optical_flow import FlowSensor

    class Board(BoardCore):
        """The board as type checkers see it: one field per kind of COMPONENTS, as
        _component_sections() builds it (tests/min/test_board_static.py compares them)."""

        servos: tuple[Servo, ...]
        sensors: tuple[Sensor, ...]
        mux: Mux | None
        motions: tuple[Motion, ...]
        motors: tuple[DcMotor, ...]
        flow_sensors: tuple[FlowSensor, ...]
        base: OmniBase | None
else:
    Board = create_model("Board", __base__=BoardCore, __module__=__name__,
                         __doc__="One board of a robot: one YAML file.", **_component_sections())


#: The PAPA-MAN command table (shared/SPEC.md, docs/protocol.md): used when a central
#: board omits ``commands:``.
DEFAULT_COMMANDS: tuple[Command, ...] = (
    Command(name="stand", prefix="t", action="stand"),
    Command(name="motor", prefix="o", action="motor"),
    Command(name="play", prefix="PLY", action="play"),
    Command(name="speeds", prefix="a", action="speeds"),
    Command(name="angles", prefix="c", action="angles"),
    Command(name="version", prefix="v", action="version"),
    Command(name="sensors", prefix="s", action="sensors"),
    Command(name="stop", prefix="x", action="stop"),
)
