"""STARFISH's boards on the PIC18F452 (issue 22, items 3, 5 and 6 in part): `esair build
starfish` builds both ports with SDCC (warnings are errors) and prints their exact
footprints; the central board's PIC build in gpsim gives the same replies, the same
I2C writes and the same flow-sensor register reads as the Python core for the same
byte stream (esair_min/pic/starfish_gpsim.py), the watchdog stop included; the drive
board's PIC build gives the Python core's duties and directions, and its timer
interrupt (two CCP PWMs and one software PWM) is timed (esair_min/pic/starfish_drive.py)."""

from __future__ import annotations

import dataclasses
from collections import Counter
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, assume, given, settings

from esair_min.cli import main
from esair_min.codegen import generate_robot
from esair_min.errors import ProtocolError
from esair_min.pic.build import BuildError, toolchain
from esair_min.pic.starfish_drive import python_drive, run_drive
from esair_min.pic.starfish_gpsim import (MARGIN, Setup, compare, differential, measure_central,
                                          python_side)
from tests.support import starfish_streams as streams

pytestmark = pytest.mark.gpsim

SCENARIO = Path(__file__).resolve().parents[1] / "scenarios" / "starfish_gpsim.txt"


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """`esair build starfish` once: (its output, the output folder)."""
    try:
        toolchain()
    except BuildError as exc:
        pytest.fail(str(exc), pytrace=False)
    out = tmp_path_factory.mktemp("starfish-pic")
    result = CliRunner().invoke(main, ["build", "starfish", "-o", str(out)])
    assert result.exit_code == 0, result.output
    return result.stdout, out


def test_build_prints_each_boards_footprint(built):
    stdout, out = built
    assert stdout.splitlines() == [
        "board    program memory           RAM (with stack)       stack",
        "central  7326 B of 32768 (22.4%)  410 B of 1536 (26.7%)  128 B",
        "drive    3412 B of 32768 (10.4%)  219 B of 1536 (14.3%)  128 B",
    ]
    for role in ("central", "drive"):
        assert (out / role / "firmware.hex").stat().st_size > 0


def test_central_in_gpsim_equals_the_python_core(built, starfish, tmp_path):
    _, out = built
    cod = out / "central" / "build-pic" / "firmware.cod"
    python, gpsim = differential(starfish, SCENARIO.read_text(), cod, tmp_path)
    assert compare(python, gpsim) == []
    # what the scenario is there to show, so the comparison cannot pass on nothing
    assert gpsim.replies[7:9] == ["TX !W watchdog stop", "TX OK n=72 a=-9,-9,0 b=-66,-66,255"]
    assert gpsim.writes == ["W 30 0038FF64006400 ACK", "W 30 00F4FFF4FFF4FF ACK",
                            "W 30 00000000000000 ACK", "W 30 009CFF32003200 ACK",
                            "W 30 00000000000000 ACK"]
    assert len(gpsim.flow[0]) == len(gpsim.flow[1]) == 3 * 92
    assert {r[:2] for r in gpsim.flow[0]} == {"02", "03", "04"}


def test_a_line_ending_on_a_tick_is_refused(starfish):
    s = Setup.from_robot(starfish)
    t2, tick = 1000, 1000 + s.tick_cycles
    rx = [(tick - 9000, ord("v")), (tick - MARGIN + 1, 0x0D)]
    with pytest.raises(ProtocolError) as exc:
        python_side(starfish, rx, t2, t2 + 3 * s.tick_cycles, [])
    assert str(exc.value) == (f"a line ends at cycle {tick - MARGIN + 1}, within {MARGIN} cycles "
                              "of a tick: which comes first is not the logic's (move the line)")
    python = python_side(starfish, [(tick - 9000, ord("v")), (tick - MARGIN, 0x0D)], t2,
                         t2 + 3 * s.tick_cycles, [])
    assert python.replies[0].startswith("TX OK esair-min/1 starfish")


# the drive board: (wanted speeds per wheel, control ticks) -- a ramp up to 300 mm/s on
# every wheel (one backwards), a ramp down caught after 3 ticks, then speeds above the
# limit (clamped to 600) with the third wheel reversed
DRIVE_STEPS = [((300, -300, 300), 40), ((0, 0, 100), 3), ((700, -700, -600), 50)]


def test_drive_in_gpsim_equals_the_python_core(built, starfish, tmp_path):
    tc = toolchain()
    _, out = built
    got = run_drive(starfish, out / "drive", DRIVE_STEPS, tmp_path, tc)
    assert got.steps == python_drive(starfish, out / "drive", DRIVE_STEPS)
    # CCP 10-bit duties (of 1000) and the software duty (of 255), directions
    assert [[(m.duty, m.dir_high) for m in row] for row in got.steps] == [
        [(396, 1), (396, 0), (101, 1)], [(317, 1), (317, 0), (81, 1)],
        [(796, 1), (796, 0), (203, 0)]]
    # the timer interrupt, entry to RETFIE inclusive, over 230 interrupts at duty 203:
    # 12 cycles with the software PWM pin on, 11 off, 16/17 when the control tick ends
    assert got.isr_cycles == Counter({12: 190, 11: 38, 16: 1, 17: 1})


def test_central_cycles_in_the_pic_build(built, starfish, tmp_path):
    _, out = built
    pic = out / "central" / "build-pic"
    got = measure_central(starfish, pic / "firmware.cod", pic / "firmware.lst", tmp_path,
                          "V-0345+0456-2789")
    # at 38400 baud: kinematics 0.70 ms; the CR of the line 1.60 ms; a tick 1.14 ms, of
    # which 6 x tSRAD (100 us) is the flow sensors' own wait (the interrupts served within
    # each span included: at 9600 baud the line's CR was 7819 cycles and the tick 5399)
    assert (got.kinematics, got.rx_line, got.tick) == (3495, 7993, 5692)


@settings(max_examples=4, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(steps=streams.steps())
def test_central_in_gpsim_equals_the_python_core_on_generated_streams(built, starfish,
                                                                      tmp_path, steps):
    _, out = built
    cod = out / "central" / "build-pic" / "firmware.cod"
    stimulus = "\n".join(steps + ["tick 2"]) + "\n"
    try:
        python, gpsim = differential(starfish, stimulus, cod, tmp_path)
    except ProtocolError as exc:        # a line ended on a tick: not a question of logic
        assume(not str(exc).startswith("a line ends at cycle"))
        raise
    assert compare(python, gpsim) == []


def test_drive_with_three_software_pwms(built, starfish, tmp_path):
    """The same drive board with every wheel on software PWM (``pwm: software``): the
    duties still equal the Python core's, and the interrupt's cost per software PWM."""
    drive = starfish.board("drive")
    soft = drive.model_copy(update={"motors": tuple(m.model_copy(update={"pwm": "software"})
                                                    for m in drive.motors)})
    robot = dataclasses.replace(starfish, boards=tuple(soft if b is drive else b
                                                       for b in starfish.boards))
    generate_robot(robot, tmp_path / "gen")
    got = run_drive(robot, tmp_path / "gen" / "drive", DRIVE_STEPS, tmp_path / "run", toolchain())
    assert got.steps == python_drive(robot, tmp_path / "gen" / "drive", DRIVE_STEPS)
    assert [m.duty for m in got.steps[-1]] == [203, 203, 203]
    # 21 cycles with the three pins off, 24 on; 26 / 29 when the control tick ends
    assert got.isr_cycles == Counter({24: 190, 21: 38, 26: 1, 29: 1})
