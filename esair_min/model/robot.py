"""A robot: its validated boards, and the views the generator and emulator need."""

from __future__ import annotations

from dataclasses import dataclass

from esair_min.model.hardware import TickBusLoad, tick_bus_load
from esair_min.components.motion.layout import ImageLayout, image_layout
from esair_min.model.board import Board, BoardDevice, Command, EepromDevice, Motion, Sensor, Servo


def frame_bus_load(central: Board, actuator: Board | None,
                   sensor: Board | None) -> TickBusLoad | None:
    """The I2C work of one frame period while a motion plays (None without motions):
    frame write, next frame read, and a sensor poll when reactions poll."""
    eeprom = central.device("eeprom")
    if actuator is None or not central.motions or not isinstance(eeprom, EepromDevice):
        return None
    polls = sensor is not None and bool(central.reactions)
    return tick_bus_load(len(actuator.servos), eeprom.address_bytes,
                         sensor.register_count if polls and sensor else 0)


@dataclass(frozen=True)
class Robot:
    """Every board of one robot, validated together. Built by :func:`validate.load_robot`."""

    name: str
    source: str
    boards: tuple[Board, ...]
    files: tuple[str, ...]  # the file each board came from, same order

    def board(self, role: str) -> Board | None:
        return next((b for b in self.boards if b.role == role), None)

    @property
    def frame_bus_load(self) -> TickBusLoad | None:
        return frame_bus_load(self.central, self.actuator, self.sensor_board)

    def file_of(self, board: Board) -> str:
        return self.files[self.boards.index(board)]

    @property
    def central(self) -> Board:
        b = self.board("central")
        assert b is not None, "validated robots have a central board"
        return b

    @property
    def actuator(self) -> Board | None:
        return self.board("actuator")

    @property
    def sensor_board(self) -> Board | None:
        return self.board("sensor")

    @property
    def servos(self) -> tuple[Servo, ...]:
        """All servos, ordered by index."""
        act = self.actuator
        return tuple(sorted(act.servos, key=lambda s: s.index)) if act else ()

    @property
    def sensors(self) -> tuple[Sensor, ...]:
        """All sensors, in register order (the order of the sensor board's file)."""
        sb = self.sensor_board
        return sb.sensors if sb else ()

    @property
    def commands(self) -> tuple[Command, ...]:
        cmds = self.central.commands
        assert cmds is not None, "validation fills the default command table"
        return cmds

    @property
    def motions(self) -> tuple[Motion, ...]:
        return self.central.motions

    def motion(self, name: str) -> Motion | None:
        return next((m for m in self.motions if m.name == name), None)

    @property
    def eeprom(self) -> EepromDevice | None:
        dev = self.central.device("eeprom")
        assert dev is None or isinstance(dev, EepromDevice)
        return dev

    def peer(self, role: str) -> BoardDevice | None:
        """The central board's device entry for the board with ``role``."""
        target = self.board(role)
        if target is None:
            return None
        for dev in self.central.i2c.devices:
            if isinstance(dev, BoardDevice) and dev.board == target.board:
                return dev
        return None

    @property
    def layout(self) -> ImageLayout:
        return image_layout(self.motions, len(self.servos))
