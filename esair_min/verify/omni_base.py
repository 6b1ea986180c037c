"""``esair verify`` for an omni base (STARFISH's kind: a central board with ``base:``).

Its stimulus scripts are STARFISH's (docs/firmware.md, "STARFISH's boards": ``rx TEXT``
sends the line and CR LF, ``raw HH ...``, ``tick N``); the default scenario uses only
those three verbs, which every target reads. The targets:

- python (esair_min.components.omni_base.harness) against host, line for line;
- pic (esair_min.pic.starfish_gpsim) and avr (esair_min.avr.starfish_simavr): the chip
  runs the script, the Python core is fed the bytes and ticks at the cycles the chip took
  them (a line end within a few hundred cycles of a tick is refused as ambiguous), and the
  replies, the I2C writes and every flow-sensor read must be equal.

Budgets: the longest line end (a ``V`` line's CR: checksum, parse, limits, kinematics,
the I2C write, the reply) against the time the 64-byte receive ring gives, one tick's
work against the tick, the AVR's worst interrupt and stack, flash and RAM of both boards.
"""

from __future__ import annotations

import subprocess
import time
from pathlib import Path
from typing import Any

from esair_min.model.robot import Robot
from esair_min.verify.budgets import Budget, memory_budgets
from esair_min.verify.compare import Comparison, Difference
from esair_min.verify.default_scenario import RING, Scenario
from esair_min.verify.result import Progress, Report
from esair_min.verify.targets import Firmware, TargetRun, VerifyError


def is_omni(robot: Robot) -> bool:
    return getattr(robot.central, "base", None) is not None


def _num(v: int) -> str:
    return f"{'+' if v >= 0 else '-'}{abs(v):04d}"


def default_scenario(robot: Robot) -> Scenario:
    """Every command with its numbers at and beyond the board files' limits, the bad
    lines, the odometry, the stop and the command watchdog."""
    base = robot.central.base
    drive = robot.board("drive")
    assert base is not None and drive is not None and robot.central.timer2 is not None
    speed, omega = base.max_speed_mm_s, base.max_omega_mrad_s
    wheel = min(m.limit_mm_s for m in drive.motors)
    watchdog = -(-base.watchdog_ms // round(robot.central.timer2.period_ms)) + 5
    lines = ["rx v", "tick 2"]
    for vx, vy, w in ((speed, 0, 0), (0, -speed, 0), (0, 0, omega), (0, 0, -omega),
                      (speed + 1, 0, 0), (0, -speed - 1, 0), (0, 0, omega + 1)):
        lines += [f"rx V{_num(vx)}{_num(vy)}{_num(w)}", "tick 2"]
    for v in (wheel, wheel + 1):
        lines += [f"rx W{_num(v)}{_num(-v)}{_num(0)}", "tick 2"]
    lines += ["rx O", "tick 2", "rx x", "tick 2", "rx v*00", "tick 2", "rx Q", "tick 2",
              "rx V+0100", "tick 2", "raw 41 80 0D 0A", "tick 2", "rx " + "V" * 44, "tick 2",
              f"rx V{_num(min(200, speed))}+0000+0000", f"tick {watchdog}", "rx O", "tick 2"]
    sc = Scenario("\n".join(lines) + "\n")
    sc.covers = [f"V at +-{speed} mm/s and +-{omega} mrad/s and one beyond",
                 f"W at {wheel} mm/s and one beyond", "O, x, v", "bad lines: E06, E01, E03, "
                 "E13, E02", f"the command watchdog ({base.watchdog_ms} ms)"]
    sc.skipped = ["flow sensors: read as the floor leaves them (no motion): their reads "
                  "are compared, their counts stay 0 (`floor`/`flow` lines are not read "
                  "by every target)"]
    return sc


def run_python(robot: Robot, script: str) -> TargetRun:
    from esair_min.components.omni_base.harness import run_script

    try:
        return TargetRun("python", run_script(robot, script))
    except ValueError as exc:
        raise VerifyError(f"script: {exc}") from None


def run_host(binary: Path, path: Path) -> TargetRun:
    proc = subprocess.run([str(binary), str(path)], capture_output=True, text=True, timeout=300)
    if proc.returncode != 0:
        raise VerifyError(f"the host build stopped: {proc.stderr.strip()[-2000:]}")
    return TargetRun("host", proc.stdout.splitlines())


def compare_host(py: TargetRun, host: TargetRun, script: str) -> Comparison:
    out = Comparison("host", len(py.trace))
    a, b = py.trace, host.trace
    if a != b:
        i = next((k for k, (x, y) in enumerate(zip(a, b)) if x != y), min(len(a), len(b)))
        out.differences.append(Difference("trace", i + 1, a[i] if i < len(a) else "(end)",
                                          b[i] if i < len(b) else "(end)"))
    return out


def run_chip(target: str, robot: Robot, script: str, fw: Firmware, work: Path) -> tuple[
        TargetRun, Comparison]:
    """The chip's run and its comparison with the Python core fed the chip's events."""
    from esair_min.errors import EsairError

    central = fw.builds["central"]
    try:
        if target == "pic":
            from esair_min.pic.starfish_gpsim import compare, differential

            py, sim = differential(robot, script, central.cod, work)
            diffs, run, raw = compare(py, sim), sim, None
        else:
            from esair_min.avr.starfish_simavr import differential as avr_differential
            from esair_min.components.omni_base.sim_replay import compare as compare_runs

            py, got = avr_differential(robot, script, central.folder / "firmware.elf")
            diffs, run, raw = compare_runs(py, got.run, "simavr"), got.run, got
    except EsairError as exc:
        raise VerifyError(f"{target}: {exc}") from None
    trace = [*run.replies, *run.writes, *(r for reads in run.flow for r in reads)]
    cmp = Comparison(target, len(trace))
    for d in diffs:
        part, _, rest = d.partition(":")
        cmp.differences.append(Difference(part, 0, "", "", note=rest.strip()))
    return TargetRun(target, trace, sim=raw), cmp      # sim: the AVR's CentralRun


def budgets(target: str, robot: Robot, fw: Firmware, run: TargetRun, work: Path) -> list[Budget]:
    central = fw.builds["central"]
    c = robot.central
    assert c.uart is not None and c.timer2 is not None and c.base is not None
    line = f"V{_num(min(200, c.base.max_speed_mm_s))}+0000{_num(min(100, c.base.max_omega_mrad_s))}"
    out: list[Budget] = []
    if target == "pic":
        from esair_min.pic.starfish_gpsim import Setup, measure_central

        s: Any = Setup.from_robot(robot)
        per_second, tick = c.mcu.clock_hz // 4, s.tick_cycles
        cyc = measure_central(robot, central.cod, central.folder / "build-pic" / "firmware.lst",
                              work / "pic-bench", line)
        unit = "instruction cycles"
        stack = 0
    else:
        from esair_min.avr.starfish_simavr import CentralSetup
        from esair_min.avr.starfish_simavr import measure_central as avr_measure

        s = CentralSetup.from_robot(robot)
        per_second, tick = c.mcu.clock_hz, s.tick_cycles
        cyc = avr_measure(robot, central.folder / "firmware.elf", line)
        unit = "cycles"
        sim = run.sim.sim
        isr = [x for spans in sim.isr_spans().values() for x in spans]
        stack = sim.stack_bytes
    byte = -(-10 * per_second // c.uart.baud)
    out.append(Budget(target, "line end (V's CR)", cyc.rx_line, RING * byte, unit,
                      f"{line}: checksum, parse, limits, kinematics ({cyc.kinematics}), the "
                      f"I2C write, the reply; the 64-byte ring at {c.uart.baud} baud: "
                      f"{RING} x {byte}",
                      f"lower uart.baud to at most {int(RING * 10 * per_second / cyc.rx_line)}"))
    out.append(Budget(target, "tick: flow reads and sums", cyc.tick, tick, unit,
                      f"one tick's core_tick, tick {c.timer2.period_ms:.3f} ms",
                      f"lengthen tick.period_ms to at least "
                      f"{cyc.tick / per_second * 1.1e3:.2f} or read fewer flow sensors"))
    if target == "avr":
        out.append(Budget(target, "worst ISR", max(isr, default=0), byte, unit,
                          f"{len(isr)} interrupts; one byte at {c.uart.baud} baud",
                          "lower uart.baud"))
        room = central.ram_bytes - central.usage.data_bytes
        out.append(Budget(target, "stack high-water", stack, room, "bytes",
                          f"{central.ram_bytes} B RAM less {central.usage.data_bytes} B of data",
                          "move the board to a part with more RAM"))
    return out + memory_budgets(fw, target, stack)


def verify_omni(robot: Robot, targets: tuple[str, ...], work: Path, script: str | None,
                name: str, say: Progress, firmware: Firmware | None) -> Report:
    from esair_min.verify.targets import prepare

    start = time.monotonic()
    sc = Scenario(script) if script is not None else default_scenario(robot)
    report = Report(robot.name, targets, sc, name or "default scenario (generated from the "
                    "board files)")
    path, firmware = prepare(robot, targets, sc.text, name if script is not None else None,
                             work, say, firmware)
    for target in targets:
        t0 = time.monotonic()
        cmp = None
        if target == "python":
            run = run_python(robot, sc.text)
        elif target == "host":
            assert firmware is not None and firmware.host is not None
            run = run_host(firmware.host, path)
            cmp = compare_host(report.runs["python"], run, sc.text)
        else:
            assert firmware is not None
            run, cmp = run_chip(target, robot, sc.text, firmware, work / target)
        run.seconds = time.monotonic() - t0
        report.runs[target] = run
        if cmp is not None:
            report.comparisons[target] = cmp
        say(f"{target}: {len(run.trace)} events in {run.seconds:.1f} s, "
            f"{'reference' if cmp is None else 'equal' if cmp.equal else 'DIFFERS'}")
        if target in ("pic", "avr"):
            assert firmware is not None
            t0 = time.monotonic()
            found = budgets(target, robot, firmware, run, work)
            report.budgets += found
            over = sum(not b.ok for b in found)
            say(f"{target} budgets: {len(found)} checked in {time.monotonic() - t0:.1f} s, "
                f"{'all within' if not over else f'{over} OVER'}")
    report.seconds = time.monotonic() - start
    return report
