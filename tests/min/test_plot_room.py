"""`esair plot` of a STARFISH trace: every legend inside the picture (the map's legend,
beside it, was cut at the figure's right edge: "path (true pos")."""

from __future__ import annotations

import subprocess
import sys

import matplotlib.pyplot as plt

from esair_min.cli.plotroom import room_figure
from tests.support.std import ROOT


def test_the_legends_are_inside_the_picture(tmp_path):
    trace = tmp_path / "sf.txt"
    subprocess.run([sys.executable, "-m", "esair_min.cli", "emulate", "starfish", "--run", "1",
                    "--send", "V+0200+0000+0000", "--trace", str(trace)], cwd=ROOT, check=True,
                   capture_output=True, timeout=120)
    fig, rows = room_figure(trace)
    try:
        assert rows == 100                       # 1 s of 10 ms ticks
        fig.canvas.draw()
        legends = [ax.get_legend() for ax in fig.axes]
        assert [lg is not None for lg in legends] == [True, True]
        assert [lg.get_texts()[0].get_text() for lg in legends] == ["path (true pose)", "wheel 0"]
        for lg in legends:
            box = lg.get_window_extent()
            assert fig.bbox.x0 <= box.x0 and box.x1 <= fig.bbox.x1, (box, fig.bbox)
            assert fig.bbox.y0 <= box.y0 and box.y1 <= fig.bbox.y1, (box, fig.bbox)
    finally:
        plt.close(fig)
    out = subprocess.run([sys.executable, "-m", "esair_min.cli", "plot", str(trace), "-o",
                          str(tmp_path / "sf.png")], cwd=ROOT, capture_output=True, text=True)
    assert (out.returncode, out.stdout) == (0, f"100 ticks -> {tmp_path / 'sf.png'}\n")
