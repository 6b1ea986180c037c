"""The template context of a drive board (wheel motors): every number its C needs,
from the model and the dc_motor kind's core (the same constants both use)."""

from __future__ import annotations

from esair_min.components.dc_motor import pwm_unit
from esair_min.components.dc_motor.core import (CONTROL_TICK_MS, SOFT_PWM_ISR_HZ, SOFT_PWM_STEPS,
                                                motor_state)
from esair_min.errors import GenerateError
from esair_min.model.robot import Robot

from . import ports
from .context import Context, _pin, common_context

#: The hardware PWM (CCP1/CCP2 on Timer2) runs at least this fast (above hearing).
MIN_CCP_PWM_HZ = 20_000
#: At most this many motors get software PWM (their duties sit in the access bank).
MAX_SOFT_PWM = 4


def drive_context(robot: Robot) -> Context:
    board = robot.board("drive")
    assert board is not None
    ctx = common_context(robot, board)
    motors = sorted(board.motors, key=lambda m: m.index)
    spec = board.spec
    rows = []
    for m in motors:
        st = motor_state(m)
        rows.append({"name": m.name, "limit": st.limit, "step": st.step,
                     "duty_q8": st.duty_q8, "reverse": int(st.reverse),
                     "unit": pwm_unit(m, spec), "pwm_pin": m.pwm_pin, "dir_pin": m.dir_pin,
                     "pwm": _pin(m.pwm_pin), "dir": _pin(m.dir_pin)})
    soft = [i for i, r in enumerate(rows) if r["unit"] == "software"]
    for k, i in enumerate(soft):
        rows[i]["soft"] = k
    ctx.update({"motors": rows, "registers": 2 * len(motors), "address": board.i2c.address,
                "soft_motors": [rows[i] for i in soft]})
    if spec.family == "avr":
        ctx["avr"] = ports.drive_avr(board, [pwm_unit(m, spec) for m in motors])
        return ctx
    if len(soft) > MAX_SOFT_PWM:
        raise GenerateError(f"drive board '{board.board}': {len(soft)} motors on software PWM, "
                            f"the PIC18F452 port has room for {MAX_SOFT_PWM}")
    ctx.update(pwm_timer(board.mcu.clock_hz))
    return ctx


def pwm_timer(clock_hz: int) -> Context:
    """Timer2 for the drive board: its period is the CCP units' PWM period, its
    postscaled interrupt (SOFT_PWM_ISR_HZ) steps the software PWM and counts the control
    tick. The longest PWM period (best duty resolution) at MIN_CCP_PWM_HZ or faster."""
    cycles = clock_hz // 4
    if cycles % SOFT_PWM_ISR_HZ:
        raise GenerateError(f"clock {clock_hz} Hz: no whole number of instruction cycles "
                            f"per software PWM step ({SOFT_PWM_ISR_HZ} Hz)")
    per_isr = cycles // SOFT_PWM_ISR_HZ
    per_tick = SOFT_PWM_ISR_HZ * CONTROL_TICK_MS // 1000
    assert per_tick * 1000 == SOFT_PWM_ISR_HZ * CONTROL_TICK_MS and per_tick <= 255
    for post in range(1, 17):
        period = per_isr // post
        if per_isr % post == 0 and period <= 256 and cycles // period >= MIN_CCP_PWM_HZ:
            break
    else:
        raise GenerateError(f"clock {clock_hz} Hz: no Timer2 setting gives a {SOFT_PWM_ISR_HZ} "
                            f"Hz interrupt with PWM at {MIN_CCP_PWM_HZ} Hz or faster")
    full = 4 * period                   # the CCP's 10-bit duty of an always-high output
    return {"pwm_t2con": ((post - 1) << 3) | 0x04, "pwm_pr2": period - 1,
            "ccp_pwm_hz": cycles // period, "pwm_isr_hz": SOFT_PWM_ISR_HZ,
            "isr_cycles": per_isr, "isr_per_tick": per_tick,
            "ccp_q6": ((full + 1) * 64 - 1) // 255,     # the largest with 255 * q >> 6 <= full
            "ccp_full": full, "soft_step": 256 // SOFT_PWM_STEPS,
            "soft_pwm_hz": SOFT_PWM_ISR_HZ / SOFT_PWM_STEPS}
