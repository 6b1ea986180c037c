"""The PIC18F452 sensor board with an analog multiplexer, run in gpsim with the mux
model (esair_min/pic/gpsim_mux.py; the ATmega328P's is simdrv.c's, tests/min/test_avr.py):
PAPA-MAN's eight feet on a 74HC4051-class 8:1 mux on AN0, as boards/papaman-avr wires
them, each read into its own register pair and read back over I2C as the central board
reads it (the master of esair_min/pic/gpsim_i2c.py, the mux working meanwhile); and a
mux slower than the board file says is caught (each conversion reads the input
selected before).

Needs the toolchain (scripts/install-toolchain.sh): without it these tests FAIL with the
install hint.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from esair_min.codegen import generate_robot
from esair_min.model.validate import load_robot
from esair_min.pic.build import BuildError, build_board, toolchain
from esair_min.pic.gpsim_i2c import GpsimSession, I2cMaster, I2cTiming
from esair_min.pic.gpsim_mux import GpsimMux, MuxSession

pytestmark = pytest.mark.gpsim

ROOT = Path(__file__).resolve().parents[2]

#: PAPA-MAN's sensor board on the PIC with papaman-avr's wiring: the eight feet on an
#: 8:1 mux, its common output on AN0, S0..S2 on RC0..RC2, 10 us to settle.
PIC_MUX8 = """\
board: sensor
role: sensor
mcu: {part: pic18f452, clock_hz: 20000000}
i2c: {mode: slave, speed_hz: 100000, address: 0x20}
mux: {channel: 0, select: [RC0, RC1, RC2], settle_us: 10}
sensors:
  - {name: l_toe_in,   mux_input: 0, group: left_foot}
  - {name: l_toe_out,  mux_input: 1, group: left_foot}
  - {name: l_heel_in,  mux_input: 2, group: left_foot}
  - {name: l_heel_out, mux_input: 3, group: left_foot}
  - {name: r_toe_in,   mux_input: 4, group: right_foot}
  - {name: r_toe_out,  mux_input: 5, group: right_foot}
  - {name: r_heel_in,  mux_input: 6, group: right_foot}
  - {name: r_heel_out, mux_input: 7, group: right_foot}
"""
#: Exact (SDCC 4.x pic16, gputils): program bytes, RAM bytes with the stack.
PIC_MUX8_SIZE = (1990, 181)
RUN = 100_000                 # instruction cycles (20 ms): several rounds of the 8 feet
_REG_RE = re.compile(r"= \$([0-9a-fA-F]+) =")


@pytest.fixture(scope="module")
def mux8(tmp_path_factory):
    """(robot, the sensor board's firmware.cod, the address of its register map)."""
    try:
        tc = toolchain()
    except BuildError as exc:
        pytest.fail(str(exc), pytrace=False)
    folder = tmp_path_factory.mktemp("mux8") / "robot"
    folder.mkdir()
    for name in ("central.yaml", "actuator.yaml"):
        (folder / name).write_text((ROOT / "boards" / "papaman" / name).read_text())
    (folder / "sensor.yaml").write_text(PIC_MUX8)
    robot = load_robot(folder)
    out = tmp_path_factory.mktemp("mux8_fw")
    generate_robot(robot, out)
    usage = build_board(out / "sensor", tc)
    assert (usage.program_bytes, usage.data_bytes) == PIC_MUX8_SIZE
    build = out / "sensor" / "build-pic"
    regs = re.search(r"^\s*_regs\s+0x([0-9a-fA-F]+)\s+data\b",
                     (build / "firmware.map").read_text(), re.M)
    assert regs, "no _regs in the map"
    return robot, build / "firmware.cod", int(regs.group(1), 16)


def register_map(session: GpsimSession, at: int, n: int) -> list[int]:
    """The sensor board's n readings as its register map holds them (low byte first)."""
    out = session.command(*(f"reg({at + i:#x})" for i in range(2 * n)))
    b = [int(m.group(1), 16) for m in map(_REG_RE.search, out) if m]
    assert len(b) == 2 * n, out
    return [b[2 * i] | b[2 * i + 1] << 8 for i in range(n)]


def counts(volts: list[float]) -> list[int]:
    return [round(v / 5 * 1023) for v in volts]


def near(got: list[int], want: list[int]) -> bool:
    return all(abs(g - w) <= 1 for g, w in zip(got, want, strict=True))


def test_the_pic_with_a_mux_reads_all_eight_feet_in_gpsim(mux8, tmp_path):
    """Each foot's voltage on its mux input reaches its own register pair, in the board
    file's order, read over I2C (the register map the central board reads with `s`),
    and again after every input changed; no conversion started before the mux had
    settled."""
    robot, cod, regs = mux8
    board = robot.sensor_board
    first = [0.0, 1.0, 2.5, 3.3, 4.99, 0.3, 5.0, 1.7]
    later = [5.0, 0.0, 0.01, 2.0, 4.0, 3.0, 0.5, 4.5]
    with MuxSession(tmp_path, timeout=300).start(cod, board.mcu.clock_hz) as session:
        mux = session.attach_mux(board, first)
        assert (mux.select, mux.channel, mux.settle_cycles) == (("RC0", "RC1", "RC2"), 0, 50)
        master = I2cMaster(session, I2cTiming.for_speed(board.i2c.speed_hz,
                                                        board.mcu.clock_hz // 4)).attach()
        got = []
        for volts in (first, later):
            mux.set_inputs(volts)
            mux.run_to(session.now + RUN)
            data = master.read_registers(board.i2c.address, 0, 16)
            got.append([data[2 * i] | data[2 * i + 1] << 8 for i in range(8)])
            assert register_map(session, regs, 8) == got[-1]      # the map, as sent
    assert near(got[0], counts(first)), (got[0], counts(first))
    assert near(got[1], counts(later)), (got[1], counts(later))
    assert mux.early == []


def test_a_conversion_before_the_mux_settles_reads_the_previous_input(mux8, tmp_path):
    """The firmware built for the board file's 10 us, on a mux that takes 90 us (450
    cycles): each conversion starts before the newly selected input shows, so each
    register pair holds the foot before it (the last foot's lands on the first's)."""
    robot, cod, regs = mux8
    board = robot.sensor_board
    volts = [0.0, 1.0, 2.5, 3.3, 4.99, 0.3, 5.0, 1.7]
    with GpsimSession(tmp_path, timeout=120).start(cod, board.mcu.clock_hz) as session:
        mux = GpsimMux.for_board(session, board, volts, settle_cycles=450).attach()
        mux.run_to(RUN)
        got = register_map(session, regs, 8)
    want = counts(volts)
    assert near(got, want[-1:] + want[:-1]), (got, want)
    assert len(mux.early) >= 8
