"""The template context of an omni base's central board (STARFISH): every number its C
needs, from the model and the kinds' Python cores (the same constants both use)."""

from __future__ import annotations

from esair_min.components.omni_base.core import WATCHDOG_NOTICE, version_line, watchdog_ticks
from esair_min.components.omni_base.kinematics import HALF, Q, wheel_table
from esair_min.components.optical_flow.core import REG_DELTA_X, REG_DELTA_Y, REG_SQUAL, T_SRAD_NS
from esair_min.core import protocol as P
from esair_min.errors import GenerateError
from esair_min.model.encoding import MAX_LINE
from esair_min.model.robot import Robot

from . import ports
from .context import Context, _clock_context, _pin, common_context

#: Instruction cycles a turn of the tSRAD wait loop (DECFSZ + BRA).
SRAD_TURN_CYCLES = 3


def omni_central_context(robot: Robot) -> Context:
    board = robot.central
    base, drive, t2 = board.base, robot.board("drive"), board.timer2
    if base is None or drive is None or t2 is None:
        raise GenerateError(f"central board '{board.board}' needs base:, tick: and a drive "
                            "board")
    ctx = common_context(robot, board)
    wheels = wheel_table(sorted(drive.motors, key=lambda m: m.index))
    tick_ns = round(t2.period_s * 1e9)
    checksum = bool(board.uart and board.uart.require_checksum)
    texts = [{"name": f"E{int(c):02d}", "text": P.ERROR_LINE[c]} for c in sorted(P.Code)]
    texts += [{"name": "OK", "text": P.OK_LINE},
              {"name": "WATCHDOG", "text": WATCHDOG_NOTICE},
              {"name": "VERSION", "text": version_line(robot.name, len(wheels),
                                                       len(board.flow_sensors),
                                                       base.watchdog_ms, checksum)}]
    ctx.update({
        "wheels": [{"s": w.s, "c": w.c, "r": w.r, "limit": w.limit_mm_s} for w in wheels],
        "flow": [{"name": f.name, "sclk": _pin(f.sclk_pin), "sdio": _pin(f.sdio_pin)}
                 for f in board.flow_sensors],
        "line_max": MAX_LINE,
        "require_checksum": int(checksum),
        "drive_address": drive.i2c.address,
        "max_v": base.max_speed_mm_s,
        "max_w": base.max_omega_mrad_s,
        "watchdog_ticks": watchdog_ticks(base.watchdog_ms, tick_ns),
        "kin_shift": Q,
        "kin_half": HALF,
        "reg_delta_y": REG_DELTA_Y, "reg_delta_x": REG_DELTA_X, "reg_squal": REG_SQUAL,
        "texts": texts,
        **_clock_context(board),
    })
    if board.spec.family == "avr":
        ctx["avr"] = ports.omni_central_avr(board)
    else:
        ctx["srad_turns"] = srad_turns(board.mcu.clock_hz)
    return ctx


def srad_turns(clock_hz: int) -> int:
    """Turns of the PIC port's tSRAD wait loop: at least T_SRAD_NS of instruction cycles."""
    cycles = -(-T_SRAD_NS * clock_hz // 4 // 1_000_000_000)
    turns = -(-cycles // SRAD_TURN_CYCLES)
    if turns > 255:
        raise GenerateError(f"clock {clock_hz} Hz: the tSRAD wait needs {turns} turns of "
                            "its loop, more than 255")
    return turns
