"""``esair new`` and ``esair verify`` (docs/verify.md): a copied robot passes check and
verify; boards broken on purpose fail with their numbers; a wrong boundary made in the
generated C is caught with the first differing event and the command that led to it.

The firmware of each robot is built once per module; the chip targets need the toolchain
(scripts/install-toolchain.sh) and fail with its install hint without it.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import pytest
from click.testing import CliRunner

from esair_min.avr.build import build_board as build_avr_board
from esair_min.cli import main
from esair_min.errors import ConfigError
from esair_min.model.validate import load_robot
from esair_min.verify.new import copy_robot
from esair_min.verify.report import report_lines
from esair_min.verify.runner import verify
from esair_min.verify.targets import VerifyError, build, build_host, choose_targets

pytestmark = [pytest.mark.avr, pytest.mark.gpsim]

ROOT = Path(__file__).resolve().parents[2]


def _copy(tmp: Path, name: str, source: str = "papaman", edits: dict | None = None) -> Path:
    folder = tmp / name
    copy_robot(source, folder)
    for file, pairs in (edits or {}).items():
        path = folder / file
        text = path.read_text()
        for old, new in pairs:
            assert text.count(old) == 1, (file, old)
            text = text.replace(old, new)
        path.write_text(text)
    return folder


def test_new_copies_a_bundled_robot_renamed_after_its_folder(tmp_path):
    written = copy_robot("papaman", tmp_path / "mybot")
    assert sorted(p.name for p in written if p.parent.name == "mybot") == [
        "actuator.yaml", "central.yaml", "sensor.yaml"]
    robot = load_robot(tmp_path / "mybot")
    assert robot.name == "mybot"
    central = (tmp_path / "mybot" / "central.yaml").read_text()
    assert "description: mybot central controller" in central
    assert "PAPA-MAN" not in central
    result = CliRunner().invoke(main, ["check", str(tmp_path / "mybot")])
    assert result.exit_code == 0 and result.output.endswith("ok\n"), result.output


def test_new_refuses_a_folder_with_files_and_an_unknown_robot(tmp_path):
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "x.yaml").write_text("x")
    with pytest.raises(ConfigError, match="not an empty folder"):
        copy_robot("papaman", tmp_path / "full")
    with pytest.raises(ConfigError, match="did you mean 'papaman'"):
        copy_robot("papamn", tmp_path / "other")
    result = CliRunner().invoke(main, ["new", "papamn", str(tmp_path / "other")])
    assert result.exit_code == 1 and "error: no bundled robot named 'papamn'" in result.output


def test_targets_follow_the_central_boards_part(robot):
    assert choose_targets(robot, None) == ("python", "host", "pic")
    assert choose_targets(robot, "pic") == ("python", "pic")
    with pytest.raises(VerifyError, match="needs a central board on the ATmega328P"):
        choose_targets(robot, "avr")
    with pytest.raises(VerifyError, match="unknown target 'arm'"):
        choose_targets(robot, "arm")


# -- PAPA-MAN made with `esair new`, on the PIC -------------------------------------------

@pytest.fixture(scope="module")
def mybot(tmp_path_factory):
    folder = _copy(tmp_path_factory.mktemp("new"), "mybot")
    robot = load_robot(folder)
    work = tmp_path_factory.mktemp("verify")
    fw = build(robot, ("python", "host", "pic"), work / "firmware")
    return robot, fw, work


@pytest.fixture(scope="module")
def mybot_report(mybot):
    robot, fw, work = mybot
    return verify(robot, ("python", "host", "pic"), work, firmware=fw)


def test_a_new_papaman_passes_verify_on_python_host_and_pic(mybot_report):
    r = mybot_report
    assert r.ok, [vars(d) for c in r.comparisons.values() for d in c.differences]
    assert set(r.comparisons) == {"host", "pic"}
    assert len(r.runs["python"].trace) == len(r.runs["host"].trace) > 1000
    replies = [bytes.fromhex(line[3:]) for line in r.runs["pic"].trace if line.startswith("TX ")]
    for code in (b"E01", b"E02", b"E03", b"E04", b"E06", b"E07", b"E08", b"E10", b"E13"):
        assert any(x.startswith(code) for x in replies), code
    budgets = {b.name: b for b in r.budgets}
    # sizes are exact (SDCC 4.2.0); the simulator figures are cycle-exact but move with
    # the firmware, so they are held to their budgets and to ranges
    assert budgets["central flash"].allowed == 32768
    assert budgets["decoder per byte"].allowed == 5209          # 10 bits at 9600 baud, 5 MIPS
    assert 30 <= budgets["decoder per byte"].used <= 300
    assert budgets["tick: frame write"].allowed == 44928        # 8.9856 ms at 5 MIPS
    assert 12_000 < budgets["tick: frame write"].used < 44_928
    assert 16 <= budgets["stack high-water"].used <= 128
    assert all(b.ok for b in r.budgets)


def test_verify_cli_json_and_exit_status(tmp_path):
    folder = _copy(tmp_path, "clibot")
    result = CliRunner().invoke(
        main, ["verify", str(folder), "--targets", "python,host", "--json"])
    assert result.exit_code == 0, result.output + result.stderr
    doc = json.loads(result.stdout)
    assert doc["ok"] and [t["target"] for t in doc["targets"]] == ["python", "host"]
    assert doc["targets"][1]["equal"] is True
    assert "host: " in result.stderr and "equal" in result.stderr        # progress lines
    bad = tmp_path / "bad.txt"
    bad.write_text("boot\nrx t\\r\ntick 1\nfrobnicate\n")
    result = CliRunner().invoke(
        main, ["verify", str(folder), "--targets", "python", "--script", str(bad)])
    assert result.exit_code == 1
    assert f"{bad}:4:1: bad script line 'frobnicate'" in result.stderr


def test_at_115200_baud_the_default_scenario_overruns_the_ring(tmp_path):
    """103 bytes arrive in a tick: the scenario adds an overrun behind a held write, and
    the host C answers it as the Python core does (E12)."""
    folder = _copy(tmp_path, "fastlink", edits={"central.yaml": [("baud: 9600", "baud: 115200")]})
    r = verify(load_robot(folder), ("python", "host"), tmp_path / "work")
    assert r.ok and "overrun (E12)" in r.scenario.covers
    assert "TX " + b"E12 input overrun\r\n".hex().upper() in r.runs["host"].trace
    slow = verify(load_robot(_copy(tmp_path, "slowlink")), ("python",), tmp_path / "w2")
    assert any(s.startswith("overrun: at 9600 baud only 9 bytes") for s in slow.scenario.skipped)


# -- boards broken on purpose ---------------------------------------------------------------

def _pic_verify(tmp: Path, folder: Path, script: str | None = None):
    robot = load_robot(folder)
    return verify(robot, ("python", "pic"), tmp / "work", script)


#: the dance, stopped: a frame write every tick (a short run at a short tick)
DANCE = "sensor 514 514 514 514 514 514 514 514\nboot\ntick 4\nrx DNC\\r\ntick 60\nrx x\\r\ntick 20\n"


def test_a_baud_that_leaves_the_decoder_too_few_cycles_fails_with_its_number(tmp_path):
    folder = _copy(tmp_path, "fastbaud", edits={"central.yaml": [("baud: 9600", "baud: 625000")]})
    r = _pic_verify(tmp_path, folder)
    assert not r.ok
    decoder = next(b for b in r.budgets if b.name == "decoder per byte")
    assert decoder.allowed == 80                       # 10 bits at 625000 baud, 5 MIPS
    assert not decoder.ok and decoder.used > 80
    assert "lower uart.baud to at most" in decoder.change
    assert all(b.ok for b in r.budgets if b.name.endswith(("flash", "RAM")))


def test_a_tick_too_short_for_its_frame_write_fails_with_its_number(tmp_path):
    folder = _copy(tmp_path, "shorttick", edits={"central.yaml": [
        ("period_ms: 8.9856", "period_ms: 2"), ("delay_ticks: 1\n", "delay_ticks: 5\n"),
        ("delay_ticks: 2\n", "delay_ticks: 5\n")]})
    r = _pic_verify(tmp_path, folder, DANCE)   # `esair check` passes it: 5 ticks per frame
    tick = next(b for b in r.budgets if b.name == "tick: frame write")
    assert tick.allowed == 10_000                     # 2 ms at 5 MIPS
    assert not tick.ok and tick.used > 12_000         # a 26-byte write alone is 11 700 on the wire
    assert "lengthen tick.period_ms to at least" in tick.change
    assert not r.ok


# -- a wrong boundary in the generated C ---------------------------------------------------

MOTOR_MAX = ("        if (outside(m)) {",
             "        if (outside(m) && num != ROM16(ES_R_LIM_MAX, m) + 1u) {")


def test_a_wrong_boundary_in_the_generated_c_is_caught_with_the_first_differing_event(
        robot, tmp_path):
    """scripts/mutation_c.py's motor-max mutant, made in the generated C only: o accepts
    a servo's max_angle + 1 on the host."""
    fw = build(robot, ("python", "host"), tmp_path / "firmware")
    core = fw.central / "core" / "central.c"
    text = core.read_text()
    assert text.count(MOTOR_MAX[0]) == 1
    core.write_text(text.replace(*MOTOR_MAX))
    fw.host = build_host(fw.central)
    r = verify(robot, ("python", "host"), tmp_path / "work", firmware=fw)
    assert not r.ok
    d = r.comparisons["host"].differences[0]
    first = robot.servos[0]
    assert d.command == f"rx oaa{first.max_angle + 1:03d}\\r"
    assert d.python == "TX " + b"E04 outside limits\r\n".hex().upper()
    assert d.target.startswith("T ")            # the host held the write for the tick
    lines = "\n".join(report_lines(r))
    assert f"after script line {d.line}: rx oaa{first.max_angle + 1:03d}" in lines
    assert "python: TX 45303420" in lines


# -- PAPA-MAN on the ATmega328P ----------------------------------------------------------------

def test_a_new_papaman_avr_passes_verify_on_python_host_and_avr(tmp_path):
    folder = _copy(tmp_path, "avrbot", source="papaman-avr")
    robot = load_robot(folder)
    r = verify(robot, ("python", "host", "avr"), tmp_path / "work")
    assert r.ok, [vars(d) for c in r.comparisons.values() for d in c.differences]
    budgets = {b.name: b for b in r.budgets}
    assert budgets["decoder per byte"].allowed == 16640         # 10 bits at UBRR0 103, 16 MHz
    assert 50 <= budgets["decoder per byte"].used <= 1000
    assert 20 <= budgets["stack high-water"].used <= 128
    assert budgets["central RAM"].used > budgets["stack high-water"].used   # data + stack
    assert "reaction auto_balance" in r.scenario.covers


# -- STARFISH (an omni base) ---------------------------------------------------------------

def test_a_new_starfish_passes_verify_on_python_host_and_pic(tmp_path):
    folder = _copy(tmp_path, "rover", source="starfish")
    robot = load_robot(folder)
    r = verify(robot, ("python", "host", "pic"), tmp_path / "work")
    assert r.ok, [vars(d) for c in r.comparisons.values() for d in c.differences]
    replies = [line for line in r.runs["python"].trace if line.startswith("TX ")]
    assert "TX E04 outside limits" in replies and "TX !W watchdog stop" in replies
    budgets = {b.name: b for b in r.budgets}
    assert budgets["tick: flow reads and sums"].allowed == 49952    # 9.9904 ms at 5 MIPS
    assert 0 < budgets["line end (V's CR)"].used < budgets["line end (V's CR)"].allowed
    assert {"central flash", "drive flash", "central RAM", "drive RAM"} <= set(budgets)


# -- the stack into the data ------------------------------------------------------------------

PAD = ("void core_tick(void)\n{\n",
       "void core_tick(void)\n{\n    { volatile uint8_t table[1700]; table[sizeof table - 1u] = 0u; }\n")


def test_a_table_on_the_stack_that_reaches_the_data_fails_with_its_number(tmp_path):
    """No board file brings the stack near the data on these parts (the AVR central's
    deepest is ~41 B of the 1 722 B left; the PIC's ~56 B of SDCC's 128 B section), so the
    table is put on the stack in the generated C: a 1 700-byte local in core_tick, which
    the AVR's stack pointer carries below the end of .bss. Caught with its number."""
    robot = load_robot(ROOT / "boards" / "papaman-avr")
    fw = build(robot, ("python", "avr"), tmp_path / "firmware")
    core = fw.central / "core" / "central.c"
    text = core.read_text()
    assert text.count(PAD[0]) == 1
    core.write_text(text.replace(*PAD))
    fw.builds["central"] = replace(fw.builds["central"], usage=build_avr_board(fw.central))
    r = verify(robot, ("python", "avr"), tmp_path / "work",
               "boot\ntick 4\nrx t\\r\ntick 14\n", firmware=fw)
    stack = next(b for b in r.budgets if b.name == "stack high-water")
    data = fw.builds["central"].usage.data_bytes
    assert stack.allowed == 2048 - data
    assert not stack.ok and stack.used > 1700
    assert "RAM" in stack.change
    assert not r.ok
