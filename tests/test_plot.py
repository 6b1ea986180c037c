"""`esair plot`: servo angles over time from a trace (simulated positions, targets)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest
from click.testing import CliRunner

from esair_min.cli import main
from esair_min.emulator import Emulator
from esair_min.errors import EsairError
from esair_min.cli.plot import plot_trace, read_trace, replay
from esair_min.core.trace import TraceWriter

ROOT = Path(__file__).resolve().parent.parent
PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def dance_trace(robot, tmp_path_factory):
    path = tmp_path_factory.mktemp("plot") / "dance.txt"
    with path.open("w") as f:
        tw = TraceWriter(f)
        emu = Emulator(robot, trace=tw)
        emu.settle()
        emu.command("oaf120")
        emu.run_for(0.1)
        emu.command("PLY03")
        emu.run_for(0.6)
        emu.close()
    return path


def test_replay_follows_the_servo_model(robot, dance_trace):
    ev = read_trace(dance_trace, 0x10)
    assert len(ev.writes) == 1 + 32          # the motor command, then 32 dance frames
    ticks, pos, tgt = replay(robot, ev)
    motor_tick = min(ev.writes)
    k = ticks.index(motor_tick)             # latched at the edge after the write
    assert [p[0] for p in pos[k:k + 6]] == [95, 100, 105, 110, 115, 120]
    assert tgt[-1] == list(robot.motion("dance").frames[-1].angles) == pos[-1]


def test_replay_agrees_with_the_emulator(robot, dance_trace):
    """The plot's positions are the emulated actuator board's, tick for tick."""
    tw = TraceWriter()
    emu = Emulator(robot, trace=tw)
    emu.settle()
    emu.command("PLY03")
    seen = {}
    for _ in range(60):
        emu.run_until(emu._tick_time(emu.ticks + 1))
        seen[emu.ticks] = emu.servo_angles
    path = dance_trace.with_name("again.txt")
    path.write_text(tw.text())
    ticks, pos, _ = replay(robot, read_trace(path, 0x10))
    for t, angles in seen.items():
        assert pos[ticks.index(t)] == angles, t


def test_plot_writes_a_png(robot, dance_trace, tmp_path):
    out = tmp_path / "motion.png"
    r = CliRunner().invoke(main, ["plot", str(dance_trace), "-o", str(out), "--targets"])
    assert r.exit_code == 0, r.output
    assert r.output.endswith(f"ticks -> {out}\n")
    assert out.read_bytes()[:8] == PNG and out.stat().st_size > 20_000


def test_plot_help_says_what_is_drawn():
    r = CliRunner().invoke(main, ["plot", "--help"])
    text = " ".join(r.output.split())
    assert "positions simulated from its actuator writes" in text


def test_plot_errors(robot, tmp_path, dance_trace):
    bad = tmp_path / "bad.txt"
    bad.write_text("hello\n")
    with pytest.raises(EsairError) as exc:
        plot_trace(robot, bad, tmp_path / "x.png")
    assert str(exc.value) == (f"{bad}: not an event trace (its first line must be "
                              "'# esair-trace 1')")
    bad.write_text("# esair-trace 1\nT 1\nW zz 00 ACK\n")
    with pytest.raises(EsairError) as exc:
        plot_trace(robot, bad, tmp_path / "x.png")
    assert str(exc.value) == f"{bad}:3: malformed trace line: 'W zz 00 ACK'"
    bad.write_text("# esair-trace 1\nT 1\nT 2\n")
    with pytest.raises(EsairError) as exc:
        plot_trace(robot, bad, tmp_path / "x.png")
    assert str(exc.value) == (f"{bad}: no writes to the actuator board (address 0x10) in "
                              "this trace")
    with pytest.raises(EsairError) as exc:
        plot_trace(robot, tmp_path / "none.txt", tmp_path / "x.png")
    assert str(exc.value) == f"cannot read the trace {tmp_path / 'none.txt'}: No such file or directory"
    with pytest.raises(EsairError) as exc:
        plot_trace(robot, dance_trace, tmp_path / "no" / "dir" / "x.png")
    assert str(exc.value) == (f"cannot write {tmp_path / 'no' / 'dir' / 'x.png'}: "
                              "No such file or directory")
    alone = dataclasses.replace(robot, boards=(robot.central,))
    with pytest.raises(EsairError) as exc:
        plot_trace(alone, dance_trace, tmp_path / "x.png")
    assert str(exc.value) == "robot papaman has no actuator board to plot"
