"""The sensor board's analog multiplexer (board file ``mux:``, sensors' ``mux_input``;
issue 24: papaman-avr's eight feet) on every port: the JSON Schema has it, a board
without one renders no mux code (PAPA-MAN's PIC firmware is byte for byte what it was),
the PIC18F452 port builds with one (SDCC, no warning) and the host port reads each
sensor from its mux input or its own channel.

The AVR port in simavr, with the driver's mux model: tests/min/test_avr.py.
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

from esair_min.codegen import generate_robot
from esair_min.model.board import Board
from esair_min.model.validate import load_robot
from esair_min.pic.build import BuildError, build_board, toolchain

ROOT = Path(__file__).resolve().parents[2]

#: PAPA-MAN's PIC sensor board with the left foot on a 4:1 mux (two select pins) on AN0
#: and the right foot on its own channels, AN4..AN7.
PIC_MUX = """\
board: sensor
role: sensor
mcu: {part: pic18f452, clock_hz: 20000000}
i2c: {mode: slave, speed_hz: 100000, address: 0x20}
mux: {channel: 0, select: [RC0, RC1], settle_us: 20}
sensors:
  - {name: l_toe_in,   mux_input: 0, group: left_foot}
  - {name: l_toe_out,  mux_input: 1, group: left_foot}
  - {name: l_heel_in,  mux_input: 2, group: left_foot}
  - {name: l_heel_out, mux_input: 3, group: left_foot}
  - {name: r_toe_in,   channel: 4, group: right_foot}
  - {name: r_toe_out,  channel: 5, group: right_foot}
  - {name: r_heel_in,  channel: 6, group: right_foot}
  - {name: r_heel_out, channel: 7, group: right_foot}
"""
# Exact (SDCC 4.x pic16, gputils): program bytes, RAM bytes with the stack.
PIC_MUX_SIZE = (1980, 181)     # PAPA-MAN's eight channels, no mux: 1804 B, 180 B


def make_host(folder: Path) -> Path:
    proc = subprocess.run(["make", "-s", "host"], cwd=folder, capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return folder / "firmware_host"


def run_host(exe: Path, script: str, tmp_path: Path) -> subprocess.CompletedProcess[str]:
    path = tmp_path / "s.txt"
    path.write_text(script)
    return subprocess.run([str(exe), str(path)], capture_output=True, text=True, timeout=60)


def registers(values: list[int]) -> str:
    return "R " + "".join(f"{v & 0xFF:02X}{v >> 8:02X}" for v in values) + "\n"


@pytest.fixture(scope="module")
def pic_mux(tmp_path_factory):
    folder = tmp_path_factory.mktemp("picmux") / "robot"
    folder.mkdir()
    for name in ("central.yaml", "actuator.yaml"):
        (folder / name).write_text((ROOT / "boards" / "papaman" / name).read_text())
    (folder / "sensor.yaml").write_text(PIC_MUX)
    out = tmp_path_factory.mktemp("picmux_fw")
    generate_robot(load_robot(folder), out)
    return out / "sensor"


def test_the_schema_has_the_mux_section():
    schema = Board.model_json_schema()
    assert set(schema["$defs"]["Mux"]["properties"]) == {"channel", "select", "settle_us"}
    assert schema["$defs"]["Mux"]["properties"]["select"]["maxItems"] == 3
    assert "mux_input" in schema["$defs"]["Sensor"]["properties"]
    assert "mux" in schema["properties"]


def test_a_board_without_a_mux_renders_no_mux_code(tmp_path):
    """PAPA-MAN's PIC boards (and papaman-avr's other boards) name no mux anywhere: the
    templates' mux parts render only for a board with ``mux:``."""
    res = generate_robot(load_robot(ROOT / "boards" / "papaman"), tmp_path / "pic")
    texts = {p: p.read_text() for p in res.files if p.suffix in (".c", ".h")}
    assert len(texts) > 20
    assert [p for p, t in texts.items() if re.search(r"\bmux", t, re.I)] == []


def test_the_pic_port_builds_with_a_mux(pic_mux):
    """The PIC18F452 port with a 4:1 mux on AN0 and four sensors on their own channels:
    SDCC builds it without a warning (build_board raises on one)."""
    try:
        tc = toolchain()
    except BuildError as exc:
        pytest.fail(str(exc), pytrace=False)
    usage = build_board(pic_mux, tc)
    hal = (pic_mux / "ports" / "pic18f452" / "hal_pic.c").read_text()
    assert "LATC |= 0x01u;              /* S0: RC0 */" in hal
    assert "TRISC &= (uint8_t)~MUX_MASK_C;" in hal
    assert (usage.program_bytes, usage.data_bytes) == PIC_MUX_SIZE


def test_the_host_port_reads_mux_inputs_and_channels(pic_mux, tmp_path):
    """Sensors 0..3 from the mux's inputs 0..3 (AN0 itself is not read), 4..7 from
    AN4..AN7; a mux input the select pins do not reach is a script error."""
    exe = make_host(pic_mux)
    script = ("mux 0 101\nmux 1 202\nmux 2 303\nmux 3 1023\nadc 0 999\n"
              "adc 4 404\nadc 5 505\nadc 6 606\nadc 7 7\nstep 16\nread 0 16\n")
    proc = run_host(exe, script, tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == registers([101, 202, 303, 1023, 404, 505, 606, 7])
    proc = run_host(exe, "mux 4 1\n", tmp_path)
    assert proc.returncode == 1
    assert proc.stderr.endswith("s.txt:1:1: mux input '4' is not a decimal number from 0 to 3\n")


def test_papaman_avr_host_port_reads_eight_feet(tmp_path):
    """papaman-avr's sensor board on the host port: its eight sensors from the eight
    inputs of the mux on ADC0, in the board file's order."""
    generate_robot(load_robot(ROOT / "boards" / "papaman-avr"), tmp_path / "fw")
    exe = make_host(tmp_path / "fw" / "sensor")
    values = [311, 522, 733, 404, 1023, 150, 620, 177]
    script = "".join(f"mux {i} {v}\n" for i, v in enumerate(values)) + "step 16\nread 0 16\n"
    proc = run_host(exe, script, tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == registers(values)


def test_esair_check_names_the_mux():
    from click.testing import CliRunner

    from esair_min.cli import main

    result = CliRunner().invoke(main, ["check", str(ROOT / "boards" / "papaman-avr")])
    assert result.exit_code == 0, result.output
    assert "  servos: 12, sensors: 8, commands: 15" in result.stdout
    assert ("  mux: 8 of 8 inputs on ADC0, select PB0, PB1, PB2 (S0 first), settling 10 us\n"
            in result.stdout)
