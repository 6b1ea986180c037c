"""STARFISH's drive board: its PIC18F452 firmware in gpsim against the Python core
(:class:`~esair_min.components.dc_motor.core.DriveCore`), and its timer interrupt timed.

gpsim runs one processor, so the central board's writes are put straight into the
slave's register map (``regs``, the array the MSSP slave interrupt fills: the code
PAPA-MAN's boards share, tested under a real I2C master in tests/min/test_gpsim_slaves.py)
with gpsim's ``reg(addr) = value``, at a fixed phase between two control ticks (Timer2
starts ~15 500 cycles after reset, the first step is at :data:`BOOT_CYCLES`). After each
step's ticks gpsim prints what drives the motors: CCPR1L/CCP1CON (CCP2's likewise), the
software PWM duties (``soft_duty<k>``) and the direction latches. They are compared with
the Python core's duty and direction after the same ticks: a CCP's 10-bit duty is
``duty * CCP_Q6 >> 6``, a software duty the duty itself.

gpsim 0.31 crashes once CCP2 is in PWM mode, so the board is built here with
``PIC_DEFS=-DES_GPSIM_CCP2_OFF`` (CCP2's mode bits stay off; its duty registers are
written as always). The timer interrupt (``pwm_isr``) is timed with execution
breakpoints on its entry and its RETFIEs over :data:`ISR_SPANS` interrupts (a whole
software PWM period and a control tick's end).
"""

from __future__ import annotations

import re
import shutil
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

from esair_min.components.dc_motor import motor_units
from esair_min.components.dc_motor.core import CONTROL_TICK_MS, DriveCore, from_s16
from esair_min.model.robot import Robot
from esair_min.pic.build import build_board
from esair_min.pic.gpsim_bench import RETURN_CYCLES, function_spans, parse_hits
from esair_min.pic.toolchain import Toolchain, ToolchainError, run_gpsim

BOOT_CYCLES = 40_000
ISR_SPANS = 230
SFR = {"CCPR1L": 0xFBE, "CCP1CON": 0xFBD, "CCPR2L": 0xFBB, "CCP2CON": 0xFBA}
LAT = {"A": 0xF89, "B": 0xF8A, "C": 0xF8B, "D": 0xF8C, "E": 0xF8D}
SOFT_DUTY_AT = 0x37           # hal_pic.c.j2: soft_duty<k> at 0x37 + k
_REG_RE = re.compile(r"\] = \$([0-9a-fA-F]+) = ")     # _CCPR1L[FIXME-ui.cc($be)] = $63 = 0b...


@dataclass(frozen=True)
class MotorOut:
    duty: int          # the software duty, or the CCP's 10-bit duty
    dir_high: int


@dataclass(frozen=True)
class DriveRun:
    steps: list[list[MotorOut]]        # after each step, per motor
    isr_cycles: Counter[int]           # pwm_isr entry..return, over ISR_SPANS interrupts


def build_for_gpsim(drive_folder: Path, work: Path, tc: Toolchain) -> Path:
    """A copy of the generated drive board built with CCP2's mode off; its .cod file."""
    if work.exists():
        shutil.rmtree(work)
    shutil.copytree(drive_folder, work, ignore=shutil.ignore_patterns("build-pic", "firmware.*"))
    build_board(work, tc, make_vars=("PIC_DEFS=-DES_GPSIM_CCP2_OFF",))
    return work / "build-pic" / "firmware.cod"


def _ccp_q6(folder: Path) -> int:
    m = re.search(r"#define CCP_Q6 (\d+)u", (folder / "ports" / "pic18f452" / "hal_pic.c").read_text())
    if not m:
        raise ToolchainError("hal_pic.c: no CCP_Q6")
    return int(m.group(1))


def _regs_address(map_text: str) -> int:
    m = re.search(r"^\s*_regs\s+0x([0-9a-fA-F]+)\s+data\s+static\s+\S*hal_pic\.asm", map_text, re.M)
    if not m:
        raise ToolchainError("firmware.map: no regs of hal_pic")
    return int(m.group(1), 16)


def _probes(robot: Robot) -> list[tuple[str, list[int]]]:
    """Per motor: its unit and the addresses gpsim prints for it (duty parts, latch)."""
    drive = robot.board("drive")
    assert drive is not None
    out = []
    for m, unit, soft in motor_units(drive.motors, drive.spec):
        if unit == "software":
            duty = [SOFT_DUTY_AT + soft]
        else:
            duty = [SFR[f"CCPR{unit[3]}L"], SFR[f"CCP{unit[3]}CON"]]
        out.append((unit, [*duty, LAT[m.dir_pin[1]]]))
    return out


def run_drive(robot: Robot, folder: Path, steps: list[tuple[tuple[int, ...], int]],
              work: Path, tc: Toolchain) -> DriveRun:
    """``steps``: (wanted speeds mm/s per motor, control ticks to run) each; the gpsim
    build of the generated drive board ``folder`` runs them."""
    drive = robot.board("drive")
    assert drive is not None and drive.mcu is not None
    cod = build_for_gpsim(folder, work / "fw", tc)
    regs = _regs_address((work / "fw" / "firmware.map").read_text())
    spans = function_spans((work / "fw" / "build-pic" / "firmware.lst").read_text(errors="replace"))
    isr = spans.get("_pwm_isr")
    if isr is None or not isr.exits:
        raise ToolchainError("firmware.lst: no pwm_isr with a return")
    tick = drive.mcu.clock_hz // 4 * CONTROL_TICK_MS // 1000
    probes = _probes(robot)
    L = [f"load {cod.resolve()}", "p18f452.BreakOnInvalidRegisterWrite = false",
         f"frequency {drive.mcu.clock_hz}"]
    now = BOOT_CYCLES
    L += [f"break c {now}", "run"]
    for speeds, ticks in steps:
        data = b"".join(bytes(from_s16(s)) for s in speeds)
        L += [f"reg({regs + i:#x}) = {b:#04x}" for i, b in enumerate(data)]
        now += ticks * tick
        L += [f"break c {now}", "run", "echo @@"]
        L += [f"reg({a:#x})" for _, addrs in probes for a in addrs]
    L += [f"break e {a:#x}" for a in (isr.entry, *isr.exits)]
    L += ["run", "cycles"] * (2 * ISR_SPANS + 1) + ["quit"]
    out = run_gpsim("\n".join(L) + "\n", work, timeout=300, tc=tc, script_name="drive.stc")
    got: list[list[MotorOut]] = []
    for chunk in out.split("@@")[1:len(steps) + 1]:
        values = [int(v, 16) for v in _REG_RE.findall(chunk)]
        row, at = [], 0
        for (unit, addrs), m in zip(probes, sorted(drive.motors, key=lambda m: m.index),
                                    strict=True):
            v = values[at:at + len(addrs)]
            at += len(addrs)
            duty = v[0] if unit == "software" else v[0] << 2 | (v[1] >> 4 & 3)
            row.append(MotorOut(duty, v[-1] >> int(m.dir_pin[2]) & 1))
        got.append(row)
    hits = parse_hits(out)
    cycles: Counter[int] = Counter()
    start = None
    for h in hits:
        if h.addr == isr.entry:
            start = h.cycle
        elif start is not None:
            cycles[h.cycle + RETURN_CYCLES - start] += 1
            start = None
    return DriveRun(got, cycles)


def python_drive(robot: Robot, folder: Path, steps: list[tuple[tuple[int, ...], int]]
                 ) -> list[list[MotorOut]]:
    """The Python core over the same steps, as the PIC's registers would show it."""
    drive = robot.board("drive")
    core = DriveCore(drive)
    q6 = _ccp_q6(folder)
    out = []
    for speeds, ticks in steps:
        core.write(0, b"".join(bytes(from_s16(s)) for s in speeds))
        for _ in range(ticks):
            core.tick()
        row = []
        for (unit, _), m in zip(_probes(robot), core.motors, strict=True):
            duty = m.duty if unit == "software" else m.duty * q6 >> 6
            row.append(MotorOut(duty, int(m.forward)))
        out.append(row)
    return out
