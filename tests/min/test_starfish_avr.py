"""STARFISH's boards on the ATmega328P in simavr (issue 24, items 2-4 for STARFISH's kinds):
`esair build starfish-avr` builds both boards with avr-gcc (warnings are errors) and
prints their exact footprints; the central board's AVR build gives the same replies, the
same I2C writes and the same flow-sensor register reads as the Python core for the same
byte stream (esair_min/avr/starfish_simavr.py), on the scenario the gpsim test runs and on
derandomized hypothesis streams, the watchdog stop included -- and the Python core equals
the host C (test_starfish_c.py) and the PIC in gpsim (test_starfish_gpsim.py), whose
literal replies and writes are asserted here too; the drive board's AVR build gives the
Python core's duties and directions and its timer interrupt is timed; both boards run
together on one TWI bus. Built once per module; marked ``avr``."""

from __future__ import annotations

import dataclasses
from collections import Counter
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, assume, given, settings

from esair_min.avr.build import build_board, elf_usage
from esair_min.avr.simavr_harness import parse_events, run_commands, symbol
from esair_min.avr.starfish_simavr import (BOOT_CYCLES, CentralSetup, differential, measure_central,
                                    python_drive, run_central, run_drive)
from esair_min.cli import main
from esair_min.codegen import generate_robot
from esair_min.components.omni_base.sim_replay import compare
from esair_min.errors import ProtocolError
from esair_min.model.validate import load_robot
from esair_min.pic.starfish_drive import MotorOut
from tests.support import starfish_streams as streams

pytestmark = pytest.mark.avr

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "tests" / "scenarios" / "starfish_gpsim.txt"
GOAL_FLASH, GOAL_RAM = 8192, 1024          # issue 24: the central board
# what the PIC build in gpsim sends and writes for SCENARIO (test_starfish_gpsim.py)
PIC_WRITES = ["W 30 0038FF64006400 ACK", "W 30 00F4FFF4FFF4FF ACK", "W 30 00000000000000 ACK",
              "W 30 009CFF32003200 ACK", "W 30 00000000000000 ACK"]
DRIVE_STEPS = [((300, -300, 300), 40), ((0, 0, 100), 3), ((700, -700, -600), 50)]


@pytest.fixture(scope="module")
def robot():
    return load_robot(ROOT / "boards" / "starfish-avr")


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """`esair build starfish-avr` once: (its output, the output folder)."""
    out = tmp_path_factory.mktemp("starfish-avr")
    result = CliRunner().invoke(main, ["build", "starfish-avr", "-o", str(out)])
    assert result.exit_code == 0, result.output
    return result.stdout, out


def elf(built, role: str) -> Path:
    return built[1] / role / "firmware.elf"


def test_build_prints_each_boards_exact_footprint_within_goal(built):
    stdout, _ = built
    # avr-gcc 5.4.0, avr-libc 2.0.0; program = .text + .data, RAM = .data + .bss
    assert stdout.splitlines() == [
        "board    program memory           RAM                            stack  mcu",
        "central  3322 B of 32768 (10.1%)  314 B of 2048 (15.3%) + stack  -      atmega328p",
        "drive    1240 B of 32768 (3.8%)   41 B of 2048 (2.0%) + stack    -      atmega328p",
        # the fuses of a bare chip, from each board file's clock (esair flash --fuses)
        "central: a bare chip at 16 MHz needs lfuse 0xFF hfuse 0xD9 efuse 0xFD "
        "(esair flash --programmer NAME --fuses)",
        "drive: a bare chip at 16 MHz needs lfuse 0xFF hfuse 0xD9 efuse 0xFD "
        "(esair flash --programmer NAME --fuses)",
    ]
    central = elf_usage(elf(built, "central"))
    assert central.program_bytes <= GOAL_FLASH and central.data_bytes <= GOAL_RAM


def test_central_in_simavr_equals_the_python_core_and_the_pic(built, robot):
    python, got = differential(robot, SCENARIO.read_text(), elf(built, "central"))
    assert compare(python, got.run, "simavr") == []
    run = got.run
    # the PIC's replies (but the robot's name in the version line) and writes
    assert run.replies[0] == "TX OK esair-min/1 starfish-avr wheels=3 flow=2 watchdog=500 checksum=off"
    assert run.replies[7:9] == ["TX !W watchdog stop", "TX OK n=72 a=-9,-9,0 b=-66,-66,255"]
    assert run.writes == PIC_WRITES
    assert len(run.flow[0]) == len(run.flow[1]) == 3 * 92
    assert {r[:2] for r in run.flow[0]} == {"02", "03", "04"}
    assert got.flow_errors == []                     # every read waited tSRAD
    # the deepest stack of the run: 314 B + 44 B = 358 B of RAM, within the 1 KB goal
    assert got.sim.stack_bytes == 44


def test_the_central_boards_texts_are_in_flash(built):
    """Every reply and notice text (es_t_*, PROGMEM) is in program memory, below the
    data space (0x800000): 560 B of RAM while they were copied to .data, 314 B now."""
    central = elf(built, "central")
    for name in ("es_t_E01", "es_t_OK", "es_t_WATCHDOG", "es_t_VERSION"):
        assert symbol(central, name) < 0x800000, name


MOTION = """rx v
flow 0 10 -3 88
flow 1 9 2 90
tick 2
rx O
flow 0 -128 127 200
tick 1
rx O
"""


def test_flow_motion_reaches_the_odometry_reply_as_in_python(built, robot):
    python, got = differential(robot, MOTION, elf(built, "central"))
    assert compare(python, got.run, "simavr") == []
    # one tick's deltas (they clear when read), then the second motion added to them
    assert got.run.replies[1:] == ["TX OK n=2 a=10,-3,88 b=9,2,90",
                                   "TX OK n=3 a=-118,124,200 b=9,2,90"]


# simavr runs a stream in a fraction of a second (gpsim: ~10 s): 12 streams, not 4
@settings(max_examples=12, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(steps=streams.steps(flow=True))
def test_central_in_simavr_equals_the_python_core_on_generated_streams(built, robot, steps):
    stimulus = "\n".join(steps + ["tick 2"]) + "\n"
    try:
        python, got = differential(robot, stimulus, elf(built, "central"))
    except ProtocolError as exc:        # a line ended on a tick: not a question of logic
        assume(not str(exc).startswith("a line ends at cycle"))
        raise
    assert compare(python, got.run, "simavr") == []


def test_drive_in_simavr_equals_the_python_core(built, robot):
    got = run_drive(robot, elf(built, "drive"), DRIVE_STEPS)
    assert got.steps == python_drive(robot, DRIVE_STEPS)
    # OCR0A, OCR0B, OCR1AL: the duty itself (of 255); directions
    assert [[(m.duty, m.dir_high) for m in row] for row in got.steps] == [
        [(101, 1), (101, 0), (101, 1)], [(81, 1), (81, 0), (81, 1)],
        [(203, 1), (203, 0), (203, 0)]]
    # Timer2's interrupt, vector to RETI, over 230 interrupts (no software PWM): 30
    # cycles, 41 when the control tick ends
    assert got.isr_cycles == Counter({30: 228, 41: 2})
    assert got.soft_high == {}


def test_drive_with_three_software_pwms(robot, tmp_path):
    """The same drive board with every wheel on software PWM (``pwm: software``)."""
    drive = robot.board("drive")
    soft = drive.model_copy(update={"motors": tuple(m.model_copy(update={"pwm": "software"})
                                                    for m in drive.motors)})
    variant = dataclasses.replace(robot, boards=tuple(soft if b is drive else b
                                                      for b in robot.boards))
    generate_robot(variant, tmp_path)
    usage = build_board(tmp_path / "drive")
    assert (usage.program_bytes, usage.data_bytes) == (1276, 44)
    got = run_drive(variant, tmp_path / "drive" / "firmware.elf", DRIVE_STEPS)
    assert got.steps == python_drive(variant, DRIVE_STEPS)
    assert [m.duty for m in got.steps[-1]] == [203, 203, 203]
    # at duty 203 the pins are on for 51 of the 64 phases: 63 cycles with the three pins
    # on, 60 off, 74/71 when the control tick ends (the PIC's assembly ISR: 24/21)
    assert got.isr_cycles == Counter({63: 177, 60: 51, 74: 1, 71: 1})
    # on the pins (simavr drives a software PWM pin; a hardware unit's pin it does not):
    # high 51/64 of four 64-step periods = 326 400 of 409 600 cycles, plus the few cycles
    # by which each pin's fall comes later in the interrupt than its rise
    assert got.soft_high == {"D6": 326415, "D5": 326411, "B1": 326407}


def test_both_boards_together_and_the_watchdog_stops_the_wheels(built, robot):
    """The central's firmware (node 0) writes the drive's firmware (node 1) over the TWI:
    after a velocity line the wheels run at the Python core's duties; 500 ms without a
    command, every duty is 0."""
    got = run_central(robot, "rx V+0200+0000+0000\ntick 30\ntick 30\n", elf(built, "central"),
                      elf(built, "drive"))
    assert got.run.replies == ["TX OK", "TX !W watchdog stop"]
    assert got.run.writes == ["W 30 0038FF64006400 ACK", "W 30 00000000000000 ACK"]
    stopped = [MotorOut(0, 1)] * 3
    # after the boot, 30 ticks (front -200 mm/s, left and right +100), 30 more, the drain
    assert got.wheels == [stopped, [MotorOut(67, 0), MotorOut(33, 1), MotorOut(33, 1)],
                          stopped, stopped]


def test_central_cycles_in_the_avr_build(built, robot):
    got = measure_central(robot, elf(built, "central"), "V-0345+0456-2789")
    # at 16 MHz: kinematics 62.6 us (the PIC: 3495 instruction cycles, 699 us); the CR
    # of the line 173 us (its reply read from flash: 2681 cycles from RAM); a tick
    # 705 us, of which 6 x tSRAD (100 us) is the sensors' wait
    assert (got.kinematics, got.rx_line, got.tick) == (1002, 2765, 11285)


FIRST_EARLY_READ = "sensor 0 at cycle 163294"     # the first tick's first read


def test_a_read_sooner_than_tsrad_is_reported_by_the_sensor_model(robot, tmp_path):
    """The sensor model checks the firmware's timing: the same central board with a 50 us
    wait instead of tSRAD's 100 us gets a report for every read."""
    generate_robot(robot, tmp_path)
    hal = tmp_path / "central" / "ports" / "atmega328p" / "hal_avr.c"
    text = hal.read_text()
    assert text.count("_delay_us(100);") == 2
    hal.write_text(text.replace("_delay_us(100);", "_delay_us(50);"))
    build_board(tmp_path / "central")
    got = run_central(robot, "tick 1\n", tmp_path / "central" / "firmware.elf")
    reads = len(got.run.flow[0]) + len(got.run.flow[1])
    assert reads == 2 * 3 * 11 and len(got.flow_errors) == reads    # 11 ticks, every read
    assert got.flow_errors[0] == FIRST_EARLY_READ


def test_bytes_faster_than_the_usart_are_counted_lost_and_the_link_recovers(built, robot):
    """40 bytes 5 cycles apart (the USART takes one a 4 160-cycle byte time): the driver
    loses every byte that finds the USART's three full (DOR); the receive interrupt
    counts each DOR it reads in ``rx_lost``, as the PIC port counts OERR; the decoder
    refuses the garbled line and answers the next one."""
    central = elf(built, "central")
    s = CentralSetup.from_robot(robot)
    lost_at = symbol(central, "rx_lost") & 0xFFFF
    cmds = [f"regs {s.drive_address} {s.drive_registers}", f"run {BOOT_CYCLES}"]
    cmds += [f"rx {BOOT_CYCLES + 5 * k} {ord('x')}" for k in range(1, 41)]
    t = BOOT_CYCLES + 200 + 5 * s.byte_cycles
    cmds += [f"rx {t + k * s.byte_cycles} {b}" for k, b in enumerate(b"\r\nv\r\n", start=1)]
    cmds += [f"run {t + 3 * s.tick_cycles}", f"peek 0 {lost_at} 1", "quit"]
    out = run_commands(central, cmds, "-")
    sim = parse_events(out, 0)
    assert (len(sim.lost), len(sim.rx) - 5) == (33, 7)      # 40 = 33 lost + 7 taken
    assert [w.split()[4] for w in out.splitlines() if w.startswith("mem ")] == ["7"]
    assert bytes(b for _, b in sim.tx).split(b"\r\n")[:2] == [
        b"E03 bad argument", b"OK esair-min/1 starfish-avr wheels=3 flow=2 watchdog=500 checksum=off"]
