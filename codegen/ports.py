"""The MCU dimension of the template context: which port folder a board gets and the
numbers its port needs (esair_min.model.mcu; the device kinds live in context.py).

A board renders the templates of its role except ``ports/<part>/`` of other parts
(``ports/host/`` always). For the PIC18F452 the context keeps its historic keys
(``timer2``, ``baud``, ``i2c``, ``pwm``, ``adc``); an ATmega328P board gets an ``avr``
dict instead, and the templates branch on ``family``.
"""

from __future__ import annotations

from typing import Any

from esair_min.components.dc_motor.core import CONTROL_TICK_MS, SOFT_PWM_ISR_HZ, SOFT_PWM_STEPS
from esair_min.components.optical_flow.core import T_SRAD_NS
from esair_min.errors import GenerateError
from esair_min.model import avr
from esair_min.model.board import Board

HOST_PORT = "host"
#: AVR software PWM: the compare fires this many Timer1 counts before an edge and the
#: ISR waits for the exact count (covers the interrupt entry and the ISR's prologue).
AVR_PWM_EARLY = 12
#: An edge nearer than this many counts is waited for inside the same ISR.
AVR_PWM_NEAR = 24
#: Pulse ends within this many counts share one edge (4 us at prescale 8, 16 MHz).
AVR_PWM_JOIN = 8


def wanted_template(name: str, role: str, part: str) -> bool:
    """Whether template ``name`` (``<role>/...``) is rendered for a board of ``part``."""
    parts = name.split("/")
    if len(parts) > 3 and parts[1] == "ports":
        return parts[2] in (HOST_PORT, part)
    return True


def mcu_context(board: Board) -> dict[str, Any]:
    """``part`` and ``family`` of the board's MCU (every board)."""
    return {"part": board.mcu.part, "family": board.spec.family}


def central_avr(board: Board) -> dict[str, Any]:
    tick, baud, twi = board.timer2, board.baud, board.i2c_setting
    if not (isinstance(tick, avr.Timer1Tick) and isinstance(baud, avr.UsartBaud)
            and isinstance(twi, avr.TwiRate)):
        raise GenerateError(f"central board '{board.board}' needs tick:, uart: and a TWI "
                            f"master on its {board.spec.name}")
    return {"tick": {"prescale": tick.prescale, "ocr1a": tick.ocr1a, "tccr1b": tick.tccr1b,
                     "cycles": tick.cycles, "period_us": round(tick.period_s * 1e6, 1)},
            "baud": {"ubrr": baud.ubrr, "u2x": baud.u2x, "rate": board.uart.baud if board.uart else 0,
                     "error_percent": round(baud.error_percent, 2)},
            "twi": {"twbr": twi.twbr, "twps": twi.twps, "speed_hz": board.i2c.speed_hz,
                    "scl_cycles": twi.scl_cycles}}


def actuator_avr(board: Board) -> dict[str, Any]:
    t = avr.servo_timer(board.mcu.clock_hz)
    if t is None:
        raise GenerateError(f"a {board.mcu.clock_hz} Hz clock gives no whole number of "
                            f"Timer1 counts in a 20 ms PWM frame")
    return {"pwm": {"prescale": t.prescale, "tccr1b": t.tccr1b, "frame": t.frame_counts,
                    "num": t.num, "den": t.den},
            "early": AVR_PWM_EARLY, "near": AVR_PWM_NEAR, "join": AVR_PWM_JOIN}


def sensor_avr(board: Board) -> dict[str, Any]:
    clock = avr.adc_clock(board.mcu.clock_hz)
    if clock is None:
        raise GenerateError(f"a {board.mcu.clock_hz} Hz clock is too fast for the ADC")
    channels = {s.channel for s in board.sensors if s.channel is not None}
    mux = None
    if board.mux is not None:
        channels.add(board.mux.channel)
        # Timer1 free-running at prescale 8 times the settling: elapsed counts >= n means
        # more than n - 1 counts passed, so n is one more than the settling's counts.
        counts = -(-board.mux.settle_us * board.mcu.clock_hz // (8 * 1_000_000)) + 1
        if counts > 0xFFFF:
            raise GenerateError(f"a mux settling time of {board.mux.settle_us} us is more "
                                f"than Timer1 counts at {board.mcu.clock_hz} Hz")
        mux = {"tccr1b": 0x02, "prescale": 8, "settle_counts": counts}
    return {"adc": {"divisor": clock.divisor, "adps": clock.adps,
                    "conversion_cycles": clock.conversion_cycles()},
            "didr0": sum(1 << ch for ch in channels if ch < 6), "mux": mux}


#: TCCRnA's COMnx1 bit (clear on up-count match: non-inverted) per hardware PWM unit.
AVR_COM = {"oc0a": 0x80, "oc0b": 0x20, "oc1a": 0x80, "oc1b": 0x20}


def drive_avr(board: Board, units: list[str]) -> dict[str, Any]:
    """The ATmega328P drive port: Timer2's CTC interrupt at SOFT_PWM_ISR_HZ (software PWM,
    control tick); Timer0/Timer1 in 8-bit phase-correct PWM (WGMn0, no prescaler) for the
    motors on their OCnx pins, OCRnx = duty: 0 always low, 255 always high."""
    clock = board.mcu.clock_hz
    t2 = avr.timer2_ctc(clock, SOFT_PWM_ISR_HZ)
    if t2 is None:
        raise GenerateError(f"clock {clock} Hz: Timer2 cannot make exactly {SOFT_PWM_ISR_HZ} "
                            "interrupts a second")
    per_tick = SOFT_PWM_ISR_HZ * CONTROL_TICK_MS // 1000
    timers = []
    for n in ("0", "1"):
        used = [u for u in units if u.startswith(f"oc{n}")]
        if used:
            timers.append({"n": n, "tccra": 0x01 | sum(AVR_COM[u] for u in used),
                           "units": [u.upper() for u in used]})
    return {"timer2": {"ocr2a": t2.ocr2a, "tccr2b": t2.tccr2b, "prescale": t2.prescale,
                       "cycles": t2.cycles},
            "isr_hz": SOFT_PWM_ISR_HZ, "isr_per_tick": per_tick,
            "soft_step": 256 // SOFT_PWM_STEPS, "soft_pwm_hz": SOFT_PWM_ISR_HZ / SOFT_PWM_STEPS,
            "pwm_hz": round(clock / 510), "timers": timers}


def omni_central_avr(board: Board) -> dict[str, Any]:
    """The ATmega328P omni central port: the central board's tick, USART and TWI numbers
    and the flow sensors' tSRAD in microseconds (avr-libc's _delay_us)."""
    return {**central_avr(board), "srad_us": -(-T_SRAD_NS // 1000)}
