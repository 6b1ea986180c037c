"""The central board's PIC firmware in gpsim with the I2C bus stuck (``fault bus`` holds
SCL low, ``fault sda`` holds SDA low: docs/trace-format.md, docs/toolchain.md).

gpsim's MSSP master never sees an ACK it should not, so this is the only way its I2C
timeout path runs: a START on a held bus is refused (a bus collision, no SSPIF), a
transfer cut by a hold never gets its STOP, and the firmware's SSPIF countdown ends in
``bus_recover`` (the MSSP reset, seen as a write to SSPCON1 with SSPEN clear, then a bus
clear). Needs the toolchain; without it these tests FAIL with the install hint. Cycle
ceilings are the measured values (deterministic) plus ~3 %.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from esair_min.errors import ProtocolError
from esair_min.pic.gpsim_harness import (GpsimRun, GpsimSetup, build_script, compare, projections,
                                     run_stimulus)
from esair_min.core.stimulus import run_script
from tests.support.board_lines import READY_BAD, READY_OK, VERSION_BAD, VERSION_OK

pytestmark = pytest.mark.gpsim

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "gpsim"
BUS = FIXTURES / "bus.txt"                # SCL held, then SDA held, commands and a motion
BUS_BOOT = FIXTURES / "bus_boot.txt"      # booting with SCL held
BUS_CUT = FIXTURES / "bus_cut.txt"        # SCL held in the middle of a frame write
CUT_LEAD = 0.25                           # bus_cut.txt: ticks end 1/4 tick after a tick

E10 = b"E10 no answer on i2c\r\n"
NOTICE = b"!E10 no answer on i2c\r\n"
OK = b"OK\r\n"
VERSION_OK = VERSION_OK
STAND = "W 10 005A145A145A145A145A145A145A145A145A145A145A145A14 ACK"

# Instruction cycles (20 MHz): from the ISR's read of the CR that ends a line to the
# reply's first byte entering the transmit ring.
TIMEOUT_MIN = 8192             # the SSPIF countdown: 4 x 256 polls of 8 cycles
HELD_WRITE_E10 = 38_800        # `t`: waits for the tick, then the START times out
BUS_COMMAND_E10 = 13_400       # PLY01, s, DNC: the read at once times out
NO_BUS_REPLY = 3_900           # v (92 bytes: measured 3 784), x, E01, E06, E03 with the bus held
MOTION_NOTICE = 9_900          # sync tick -> !E10 of a frame write refused
CUT_NOTICE = 17_700            # hold begins mid-write -> !E10


@pytest.fixture(scope="module")
def central(pic_firmware):
    """The generated central firmware built for the PIC: its .cod file."""
    return pic_firmware("central") / "build-pic" / "firmware.cod"


@pytest.fixture(scope="module")
def bus_run(robot, central, tmp_path_factory) -> GpsimRun:
    return run_stimulus(robot, BUS.read_text(), central, tmp_path_factory.mktemp("bus"))


def held(run: GpsimRun, cycle: int) -> bool:
    return any(a <= cycle <= b for a, b in run.holds)


def answers(run: GpsimRun) -> list[tuple[int, int, bytes, int]]:
    """Each command line: (cycle its CR was read, cycles to its reply, the reply, MSSP
    resets in between). The reply is the first line after the CR that is not a notice."""
    replies = run.reply_times()
    out = []
    for cr in (c for c, b in run.rx if b == 0x0D):
        queued, line = next((q, r) for q, r in replies if q > cr and not r.startswith(b"!"))
        out.append((cr, queued - cr, line, sum(1 for r in run.bus_resets if cr < r < queued)))
    return out


def test_held_bus_replies_equal_the_python_core(robot, bus_run):
    python = run_script(robot, BUS.read_text())
    assert compare(python, bus_run.trace(), GpsimSetup.from_robot(robot), held=True) == []
    assert [line for _, line in bus_run.replies] == [
        READY_OK, OK,
        NOTICE, E10, E10, E10, E10,                        # held SCL: poll, t, PLY01, s, DNC
        VERSION_OK, OK, b"E01 unknown command\r\n", b"E06 bad checksum\r\n",
        b"E03 bad argument\r\n",                           # v, x, zebra, t*75, ozz100
        OK, OK, NOTICE, NOTICE, OK,                        # released t; PLY01 stopped mid-way
        NOTICE, E10, E10, VERSION_OK, OK]                  # held SDA: poll, t, s, v; released t


def test_every_failed_transfer_costs_one_timeout(robot, bus_run):
    """The PIC resets its MSSP exactly once per transfer the Python core saw fail, and
    only while a line is held."""
    python = run_script(robot, BUS.read_text())
    failed = [line for line in python if line[:2] in ("W ", "R ") and line.endswith("NACK")]
    assert len(bus_run.bus_resets) == len(failed) == 38
    assert all(held(bus_run, c) for c in bus_run.bus_resets)


def test_commands_needing_the_bus_get_e10_within_a_ceiling(bus_run):
    stuck = [a for a in answers(bus_run) if held(bus_run, a[0])]
    need = [(cycles, resets) for _, cycles, line, resets in stuck if line == E10]
    assert len(need) == 6                                  # t, PLY01, s, DNC; t, s
    assert all(resets == 1 for _, resets in need)          # one timeout each
    assert all(cycles > TIMEOUT_MIN for cycles, _ in need)
    held_writes = [need[0][0], need[4][0]]                 # the two `t`
    at_once = [c for i, (c, _) in enumerate(need) if i not in (0, 4)]
    assert max(held_writes) <= HELD_WRITE_E10
    assert max(at_once) <= BUS_COMMAND_E10


def test_commands_not_needing_the_bus_answer_as_usual(bus_run):
    stuck = [a for a in answers(bus_run) if held(bus_run, a[0])]
    other = [(cycles, line, resets) for _, cycles, line, resets in stuck if line != E10]
    assert [line[:3] for _, line, _ in other] == [b"OK ", b"OK\r", b"E01", b"E06", b"E03",
                                                  b"OK "]
    assert all(resets == 0 for *_, resets in other)
    assert max(cycles for cycles, *_ in other) <= NO_BUS_REPLY


def test_a_motion_playing_when_the_bus_sticks_stops_with_a_notice(bus_run):
    """sit (PLY01) writes a frame every 20 ticks; SCL is held after the first one: the
    second one's write is refused at its tick and !E10 follows within a ceiling."""
    play = next(cr for cr, _, line, _ in answers(bus_run) if cr > 7_000_000 and line == OK)
    hold = next(h for h in bus_run.holds if h[0] > play)
    rises = [c for c, v in bus_run.sync_edges if v == 1]
    notices = [q for q, line in bus_run.reply_times() if line == NOTICE and hold[0] < q < hold[1]]
    assert len(notices) == 2                               # the first failing poll, the motion
    motion = notices[1]
    tick = max(c for c in rises if c < motion)
    assert sum(1 for r in bus_run.bus_resets if tick < r < motion) == 1
    assert TIMEOUT_MIN < motion - tick <= MOTION_NOTICE
    frames = [t for t in bus_run.transfers
              if t.segments and t.segments[0].address == 0x10 and play < t.start < hold[1]]
    assert len(frames) == 1 and frames[0].stop < hold[0]  # only the first frame went out


def test_the_timer2_tick_keeps_running_while_the_bus_is_held(robot, bus_run):
    """Every Timer2 period inside a hold gives a sync rising edge: no tick is lost
    (a lost tick leaves the pin high, so two periods pass between rises)."""
    period = GpsimSetup.from_robot(robot).tick_cycles
    rises = [c for c, v in bus_run.sync_edges if v == 1]
    for a, b in bus_run.holds:
        inside = [c for c in rises if a <= c <= b]
        assert len(inside) >= (b - a) // period - 1
        assert all(abs(y - x - period) <= 20 for x, y in zip(inside, inside[1:]))


def test_after_release_the_next_stand_is_written_and_answered_ok(bus_run):
    ends = [b for _, b in bus_run.holds]
    after = [next(a for a in answers(bus_run) if a[0] > end) for end in ends]
    assert [line for _, _, line, _ in after] == [OK, OK, OK]
    lines = {t.start: t.trace_line() for t in bus_run.transfers if t.segments}
    for cr, cycles, _, resets in after:
        assert resets == 0
        assert [line for start, line in lines.items() if cr < start < cr + cycles] == [STAND]


def test_booting_with_the_bus_held_reports_a_bad_image(robot, central, tmp_path):
    run = run_stimulus(robot, BUS_BOOT.read_text(), central, tmp_path)
    python = run_script(robot, BUS_BOOT.read_text())
    assert compare(python, run.trace(), GpsimSetup.from_robot(robot), held=True) == []
    assert [line for _, line in run.replies] == [
        READY_BAD, NOTICE,
        VERSION_BAD, E10,
        b"E09 motion image invalid\r\n", OK, b"E09 motion image invalid\r\n",
        b"OK 514,514,514,514,514,514,514,514\r\n"]
    assert run.bus_resets[0] < run.replies[0][0]           # the header read timed out


def test_a_transfer_cut_mid_byte_fails_and_the_bus_recovers(robot, central, tmp_path):
    """SCL held in the middle of a dance frame write. gpsim's MSSP clocks on blind (it
    does not sense SCL while sending), the STOP cannot happen and times out; the
    actuator stand-in is left in the middle of a byte holding SDA low, so after the
    release the next START fails too and bus_recover's bus clear (nine SCL pulses and a
    STOP) frees it: the following `t` is written and answered OK. The Python core's
    ticks are atomic (its write of that tick is whole), so only the replies compare."""
    run = run_stimulus(robot, BUS_CUT.read_text(), central, tmp_path, lead=CUT_LEAD)
    python = run_script(robot, BUS_CUT.read_text())
    setup = GpsimSetup.from_robot(robot)
    addresses = setup.eeprom_address, setup.actuator_address, setup.sensor_address
    assert projections(python, *addresses)["uart"] == projections(run.trace(), *addresses)["uart"]
    assert [line for _, line in run.replies] == [
        READY_OK, OK, NOTICE, NOTICE, OK]
    (hold,) = run.holds
    cut = [t for t in run.transfers if t.cut]
    assert len(cut) == 1 and cut[0].segments[0].address == setup.actuator_address
    line = cut[0].trace_line()                       # W 10 <bytes on the wire> NACK
    acked = [p for p in python if p.startswith("W 10 ") and p.endswith(" ACK")]
    assert any(p.split()[2].startswith(line.split()[2]) for p in acked)
    assert 0 < hold[0] - cut[0].start < 12_767              # on the wire when SCL was held
    notice = next(q for q, r in run.reply_times() if r == NOTICE)
    assert TIMEOUT_MIN < notice - hold[0] <= CUT_NOTICE
    assert len([r for r in run.bus_resets if r > hold[1]]) <= 1   # the release's first START
    cr, cycles, line, _ = answers(run)[-1]                  # `t` after the release
    assert line == OK and cr > hold[1]
    assert [t.trace_line() for t in run.transfers if cr < t.start < cr + cycles] == [STAND]


# -- the harness's pieces, without gpsim ---------------------------------------------

def test_hold_commands_in_the_gpsim_script(robot):
    script, _ = build_script(robot, "fault bus on\nboot\nfault sda on\nfault bus off\n"
                             "fault sda off\n", "fw.cod", "image.hex")
    lines = script.splitlines()
    held = [line for line in lines if line.startswith(("PSCL.voltage", "PSDA.voltage"))]
    assert held == ["PSCL.voltage = 0.0", "PSDA.voltage = 0.0", "PSCL.voltage = 5.0",
                    "PSDA.voltage = 5.0"]
    assert {"log w _SSPCON1", "log r _RCREG", "log w _PIE1"} <= set(lines)


def test_unknown_line_is_refused_by_the_gpsim_harness(robot):
    with pytest.raises(ProtocolError, match=r"stimulus line 2: 'wiggle' is not supported by the "
                                            r"gpsim harness \(boot, rx, tick, sensor, "
                                            r"fault sensor\|bus\|sda, poke\)"):
        build_script(robot, "boot\nwiggle\n", "fw.cod", "image.hex")
