"""The template context of a drive board (wheel motors): every number its C needs,
from the model and the dc_motor kind's core (the same constants both use)."""

from __future__ import annotations

from esair_min.components.dc_motor import pwm_unit
from esair_min.components.dc_motor.core import motor_state
from esair_min.model.robot import Robot

from .context import Context, common_context


def drive_context(robot: Robot) -> Context:
    board = robot.board("drive")
    assert board is not None
    ctx = common_context(robot, board)
    motors = sorted(board.motors, key=lambda m: m.index)
    rows = []
    for m in motors:
        st = motor_state(m)
        rows.append({"name": m.name, "limit": st.limit, "step": st.step,
                     "duty_q8": st.duty_q8, "reverse": int(st.reverse),
                     "unit": pwm_unit(m), "pwm_pin": m.pwm_pin, "dir_pin": m.dir_pin})
    ctx.update({"motors": rows, "registers": 2 * len(motors), "address": board.i2c.address})
    return ctx
