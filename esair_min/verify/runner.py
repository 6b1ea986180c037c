"""``esair verify``: one scenario through every target, the traces compared with the
Python core's, the chip simulators' budgets (docs/verify.md)."""

from __future__ import annotations

import time
from pathlib import Path

from esair_min.model.robot import Robot
from esair_min.verify import budgets as B
from esair_min.verify.compare import compare_chip, compare_host
from esair_min.verify.omni_base import is_omni, verify_omni
from esair_min.verify.result import Progress, Report
from esair_min.verify.default_scenario import Scenario, default_scenario
from esair_min.verify.targets import (Firmware, TargetRun, VerifyError, avr_watch, prepare,
                                      run_avr, run_host, run_pic, run_python)




def verify(robot: Robot, targets: tuple[str, ...], work: Path, script: str | None = None,
           script_name: str = "", progress: Progress | None = None,
           firmware: Firmware | None = None) -> Report:
    """Run the scenario (``script``, or the default one generated from the board files)
    on ``targets`` (python first); firmware is built in ``work`` unless given."""
    say = progress or (lambda _text: None)
    start = time.monotonic()
    if is_omni(robot):
        return verify_omni(robot, targets, work, script, script_name, say, firmware)
    if robot.central.role != "central" or robot.eeprom is None or not robot.commands:
        raise VerifyError(f"'{robot.name}': esair verify runs robots whose central board has "
                          "a command table and a motion EEPROM (PAPA-MAN's kind) or an omni "
                          "base (STARFISH's); its "
                          f"central board '{robot.central.board}' has none")
    sc = Scenario(script) if script is not None else default_scenario(robot, targets)
    name = script_name or "default scenario (generated from the board files)"
    report = Report(robot.name, targets, sc, name)
    path, firmware = prepare(robot, targets, sc.text, script_name if script is not None else None,
                             work, say, firmware)
    for target in targets:
        t0 = time.monotonic()
        run = _run(target, robot, sc.text, path, firmware, work)
        run.seconds = time.monotonic() - t0
        report.runs[target] = run
        py = report.runs["python"]
        if target == "host":
            report.comparisons[target] = compare_host(py, run, sc.text)
        elif target in ("pic", "avr"):
            report.comparisons[target] = compare_chip(py, run, sc.text, robot)
        verdict = ("reference" if target == "python" else
                   "equal" if report.comparisons[target].equal else "DIFFERS")
        say(f"{target}: {len(run.trace)} events in {run.seconds:.1f} s, {verdict}")
        if target in ("pic", "avr"):
            assert firmware is not None
            t0 = time.monotonic()
            found = _budgets(target, robot, firmware, run, py, sc.text, work)
            report.budgets += found
            over = sum(not b.ok for b in found)
            say(f"{target} budgets: {len(found)} checked in {time.monotonic() - t0:.1f} s, "
                f"{'all within' if not over else f'{over} OVER'}")
    report.seconds = time.monotonic() - start
    return report


def _run(target: str, robot: Robot, script: str, path: Path, fw: Firmware | None,
         work: Path) -> TargetRun:
    if target == "python":
        return run_python(robot, script, str(path))
    assert fw is not None
    if target == "host":
        assert fw.host is not None
        return run_host(fw.host, path)
    if target == "pic":
        lst = fw.builds["central"].folder / "build-pic" / "firmware.lst"
        prologue, epilogue, _ = B.pic_stack_commands(lst)
        return run_pic(robot, script, fw, work / "pic", epilogue, prologue)
    return run_avr(robot, script, fw, work / "avr")


def _budgets(target: str, robot: Robot, fw: Firmware, run: TargetRun, py: TargetRun,
             script: str, work: Path) -> list[B.Budget]:
    central = fw.builds["central"]
    if target == "pic":
        from esair_min.codegen.context import PIC_STACK
        from esair_min.pic.toolchain import ToolchainError

        lst = central.folder / "build-pic" / "firmware.lst"
        try:
            decoder, isr, lost = B.pic_decoder(robot, B.decoder_stimulus(robot), central.cod,
                                               lst, work / "pic-decoder")
        except ToolchainError as exc:
            raise VerifyError(f"gpsim (decoder bench): {exc}") from None
        _, _, area = B.pic_stack_commands(lst)
        stack = B.pic_stack_bytes(run.sim.output, area, PIC_STACK["size"])
    else:
        elf = central.folder / "firmware.elf"
        from esair_min.avr.simavr_harness import run_stimulus

        watch = avr_watch(elf)
        bench = run_stimulus(robot, B.decoder_stimulus(robot), elf, work / "avr-decoder",
                             isrs=True, watch=watch)
        decoder = B.avr_decoder(bench, watch[0])
        lost = len(bench.lost)
        isr = [s for spans in run.sim.isr_spans().values() for s in spans]
        stack = run.sim.stack_bytes
    return (B.chip_budgets(robot, fw, run, py, decoder, isr, stack, script, lost)
            + B.memory_budgets(fw, target, stack))
