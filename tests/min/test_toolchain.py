"""The PIC18F452 toolchain end to end: SDCC builds, gplink maps, gpsim runs.

These tests need scripts/install-toolchain.sh to have run. Without the
toolchain they FAIL with ToolchainError's message (CI installs it first).
"""
from __future__ import annotations

import statistics
from pathlib import Path

import pytest

from esair_min.pic.toolchain import (ToolchainError, Toolchain, compile_and_link, find_toolchain,
                                 parse_map, run_gpsim)

pytestmark = pytest.mark.gpsim

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "pic"
PIC_PREAMBLE = """\
load {cod}
p18f452.BreakOnInvalidRegisterWrite = false
frequency 20000000
module library libgpsim_modules.so.0
"""


def require_toolchain() -> Toolchain:
    try:
        return find_toolchain()
    except ToolchainError as exc:
        pytest.fail(str(exc), pytrace=False)


def build(tc: Toolchain, name: str, workdir: Path) -> Path:
    hex_path = compile_and_link(tc, [FIXTURES / f"{name}.c"], workdir, name=name)
    assert hex_path.exists()
    return hex_path.with_suffix(".cod")


def test_missing_toolchain_raises_with_install_hint(tmp_path, monkeypatch):
    monkeypatch.setenv("ESAIR_TOOLCHAIN", str(tmp_path / "nowhere"))
    with pytest.raises(ToolchainError, match="run scripts/install-toolchain.sh"):
        find_toolchain()


def test_parse_map_counts_program_and_ram_including_stack(tmp_path):
    (tmp_path / "fw.map").write_text(
        "                 .idata_i    romdata   0x000004    program   0x000002\n"
        ".config_300001_X.O    romdata   0x300001    program   0x000001\n"
        "         S_crt0iz___entry       code   0x000000    program   0x000004\n"
        "               .registers      udata   0x000000       data   0x000004\n"
        "            stack_section      udata   0x000100       data   0x000100\n"
        "                 sfr_0f81      udata   0x000f81       data   0x000001\n"
        "                            7 program addresses used\n")
    usage = parse_map(tmp_path / "fw.map")
    assert (usage.program_bytes, usage.data_bytes, usage.stack_bytes,
            usage.program_addresses_used) == (6, 260, 256, 7)


def test_usart_firmware_links_and_maps(tmp_path):
    tc = require_toolchain()
    cod = build(tc, "usart_ok", tmp_path)
    usage = parse_map(cod.with_suffix(".map"))
    assert 0 < usage.program_bytes < 32768
    assert usage.stack_bytes == 256
    assert usage.stack_bytes < usage.data_bytes < 1536


def test_usart_sends_ok_and_timer2_toggles_rb0(tmp_path):
    tc = require_toolchain()
    cod = build(tc, "usart_ok", tmp_path)
    script = PIC_PREAMBLE.format(cod=cod.name) + """\
module load usart U1
U1.txbaud = 9600
U1.rxbaud = 9600
U1.console = true
node ntx
node nrx
attach ntx portc6 U1.RXPIN
attach nrx portc7 U1.TXPIN
module load FileRecorder FR
FR.digital = true
FR.file = "rb0.txt"
node nrb0
attach nrb0 portb0 FR.pin
break c 60000
run
FR.file = "/dev/null"
_sent
quit
"""
    out = run_gpsim(script, tmp_path, timeout=60, tc=tc)
    received = out.split("running...\n", 1)[1].split("cycle break", 1)[0]
    assert received == "OK\r\n"
    assert "_sent = 0x1" in out
    edges = [int(c) for c, v in (line.split() for line in
                                 (tmp_path / "rb0.txt").read_text().splitlines())
             if v in ("0", "1") and int(c) > 0]
    assert len(edges) > 100
    assert statistics.median(b - a for a, b in zip(edges, edges[1:])) == 250


def test_i2c_master_writes_and_reads_back_24lc256(tmp_path):
    tc = require_toolchain()
    cod = build(tc, "i2c_eeprom", tmp_path)
    script = PIC_PREAMBLE.format(cod=cod.name) + """\
module load e24xx256 EE
module load pullup PU1
module load pullup PU2
node nscl
node nsda
attach nscl portc3 EE.SCL PU1.pin
attach nsda portc4 EE.SDA PU2.pin
break w _done == 1
break c 2000000
run
_readback
_acks
_err
EE.eeData[0x123]
quit
"""
    out = run_gpsim(script, tmp_path, timeout=60, tc=tc)
    assert "Hit a Breakpoint!" in out, out[-1500:]
    assert "_err = 0x0" in out
    assert "_acks = 0xff" in out           # all 8 address/data bytes ACKed
    assert "_readback = 0xa5" in out
    assert "EE.eeData[$123] = $a5" in out
