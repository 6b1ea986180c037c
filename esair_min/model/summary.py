"""The short human summary ``esair check`` prints for a valid robot."""

from __future__ import annotations

from esair_min.components import COMPONENTS
from esair_min.model.hardware import FIRMWARE_BUS_OVERHEAD
from esair_min.model.board import Board
from esair_min.model.robot import Robot


def robot_summary(robot: Robot) -> list[str]:
    c = robot.central
    lines = [f"robot '{robot.name}': {len(robot.boards)} boards "
             f"({', '.join(f'{b.board} [{b.role}]' for b in robot.boards)})"]
    names = ", ".join(m.name for m in sorted(robot.motions, key=lambda m: m.number))
    lines.append(f"  servos: {len(robot.servos)}, sensors: {len(robot.sensors)}, "
                 f"commands: {len(robot.commands)}, motions: {len(robot.motions)}"
                 f"{f' ({names})' if names else ''}, reactions: {len(c.reactions)}")
    eeprom = robot.eeprom
    if eeprom is not None:
        used = robot.layout.total_bytes
        lines.append(f"  EEPROM '{eeprom.name}': {used} of {eeprom.size_bytes} bytes used "
                     f"({100.0 * used / eeprom.size_bytes:.1f} %)")
    t2 = c.timer2
    if t2 is not None:
        lines.append(f"  tick: {t2.period_ms:.4f} ms ({t2.describe(c.mcu.clock_hz)})")
    baud = c.baud
    if baud is not None and c.uart is not None:
        lines.append(f"  UART: {c.uart.baud} baud, {baud.describe().replace(' with ', ' ')}, "
                     f"error {baud.error_percent:+.2f} %")
    i2c = c.i2c_setting
    if i2c is not None:
        lines.append(f"  I2C: {c.i2c.speed_hz} Hz, {i2c.describe()}")
    load = robot.frame_bus_load
    if load is not None and t2 is not None and c.i2c is not None:
        wire = load.seconds(c.i2c.speed_hz)
        poll = f" + sensor poll {load.poll}" if load.poll else ""
        lines.append(f"  bus per frame: write {load.write} + next frame read {load.read}"
                     f"{poll} bit times = {wire * 1e3:.2f} ms, {wire / t2.period_s:.0%} of a "
                     f"tick on the wire (the {'PIC' if c.spec.family == 'pic18' else 'AVR'} master "
                     f"needs {FIRMWARE_BUS_OVERHEAD}x that)")
    for b in robot.boards:
        for kind in COMPONENTS:
            if kind.summary is not None and kind.items(b):
                lines += kind.summary(b)
    return lines


def board_summary(board: Board, folder: str) -> list[str]:
    """What ``esair check`` prints for one board file checked on its own."""
    parts = [f"servos: {len(board.servos)}"] if board.servos else []
    if board.sensors:
        parts.append(f"sensors: {len(board.sensors)}")
    if board.motors:
        parts.append(f"motors: {len(board.motors)}")
    if board.role == "central":
        parts += [f"commands: {len(board.commands or ())}", f"motions: {len(board.motions)}",
                  f"reactions: {len(board.reactions)}"]
    where = (f"I2C slave at 0x{board.i2c.address:02X}" if board.i2c.address is not None
             else "I2C master")
    return [f"board '{board.board}' [{board.role}], {where}: {', '.join(parts) or 'no parts'}",
            "  checked on its own: the rules between boards (addresses, register counts, "
            "motions against servos, reactions against sensor groups) need all of the "
            f"robot's board files: esair check {folder}"]
