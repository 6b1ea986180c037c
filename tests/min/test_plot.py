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

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
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


def _figure(robot, trace, targets=False):
    import matplotlib

    matplotlib.use("Agg")
    from esair_min.cli.plotdraw import draw

    ev = read_trace(trace, 0x10, 0x20)
    ticks, pos, tgt = replay(robot, ev)
    return ev, draw(robot, ev, ticks, pos, tgt, robot.central.timer2.period_s, targets,
                    Path(trace).name)


@pytest.fixture(scope="module")
def push_trace(robot, tmp_path_factory):
    path = tmp_path_factory.mktemp("plot") / "push.txt"
    with path.open("w") as f:
        emu = Emulator(robot, scenario="push", trace=TraceWriter(f))
        emu.settle()
        emu.command("PLY03")
        emu.run_for(2.5)
        emu.close()
    return path


def test_one_panel_per_joint_the_feet_below_and_the_legend_outside(robot, push_trace):
    import matplotlib.pyplot as plt

    ev, fig = _figure(robot, push_trace, targets=True)
    try:
        axes = fig.get_axes()
        titles = [ax.get_title(loc="left") for ax in axes]
        assert titles[:12] == [s.name for s in robot.servos if s.name.startswith("l_")] + \
            [s.name for s in robot.servos if s.name.startswith("r_")]
        assert titles[12:] == ["foot sensors as the central board read them (ADC counts)",
                               "what the balance reaction compares"]
        assert len({ax.get_xlim() for ax in axes}) == 1          # one time axis for all
        # the reaction fired and is marked on every panel, feet and balance included
        assert ev.reactions and all(
            sum(1 for ln in ax.get_lines() if ln.get_color() == "red") == len(ev.reactions)
            for ax in axes)
        # the feet: each group's sum as read; the push shows, the threshold is drawn
        feet = axes[12].get_lines()
        assert max(feet[0].get_ydata()) == 680 * 4 and min(feet[1].get_ydata()) == 340 * 4
        assert any(list(ln.get_ydata()) == [400, 400] for ln in axes[13].get_lines())
        # the figure legend stands above every panel: outside the data
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        legend = fig.legends[0].get_window_extent(renderer)
        assert all(legend.y0 >= ax.get_window_extent(renderer).y1 for ax in axes)
        assert [t.get_text() for t in fig.legends[0].get_texts()] == [
            "simulated position", "target", "reaction fired (auto_balance)"]
    finally:
        plt.close(fig)


def test_an_idle_trace_is_drawn_flat_with_a_note(robot, tmp_path):
    import matplotlib.pyplot as plt

    idle = tmp_path / "idle.txt"
    with idle.open("w") as f:
        emu = Emulator(robot, trace=TraceWriter(f))
        emu.run_for(0.5)
        emu.close()
    ev, fig = _figure(robot, idle)
    try:
        assert not ev.writes and ev.readings
        assert fig._suptitle.get_text().endswith(
            "no writes to the actuator board in this trace: the servos held the stand pose "
            "throughout")
        for ax, _servo in zip(fig.get_axes()[:12], sorted(robot.servos, key=lambda s: s.name[0])):
            ys = set(ax.get_lines()[0].get_ydata())
            assert len(ys) == 1                                    # flat
    finally:
        plt.close(fig)
    out = tmp_path / "idle.png"
    r = CliRunner().invoke(main, ["plot", str(idle), "-o", str(out)])
    assert r.exit_code == 0, r.output
    assert out.read_bytes()[:8] == PNG
