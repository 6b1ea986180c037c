"""Components run in the user's folder, and the deployment's folder serves only the
deployment's own modules (issue 34 item 3): a relative path a behavior writes lands where
`esair std run` was started, never in the (read-only, installed) deployment folder, and a
file of that folder named like an installed module (numpy.py, colorsys.py) shadows
nothing; in both modes."""

import json
import os
import stat

import pytest

from tests.support.std import MODES, esair, free_endpoint

MINE = '''\
import json
import os

import colorsys
import numpy

import helper                 # a neighbour of this module: still found
from esair_std import Behavior


class Where(Behavior):
    period = 0.05

    def start(self):
        os.makedirs("out", exist_ok=True)
        with open("out/where.json", "w") as f:      # relative: the folder it runs in
            json.dump({"cwd": os.getcwd(), "numpy": numpy.__file__,
                       "colorsys": colorsys.__file__, "helper": helper.__file__,
                       "ndarray": hasattr(numpy, "ndarray")}, f)
'''

SHADOW = "raise ImportError('the deployment folder shadowed an installed module')\n"


def _files(folder):
    return sorted(os.path.relpath(os.path.join(d, f), folder) for d, dirs, fs in os.walk(folder)
                  for f in fs if "__pycache__" not in d)


@pytest.mark.parametrize("mode", MODES)
def test_a_read_only_deployment_folder_gets_nothing_and_shadows_nothing(mode, tmp_path):
    install, run = tmp_path / "install" / "robot", tmp_path / "run"
    install.mkdir(parents=True)
    run.mkdir()
    (install / "robot.yaml").write_text(f"robot: t\nmode: {mode}\nbehaviors:\n"
                                        "  where: {class: 'mine:Where'}\n")
    (install / "mine.py").write_text(MINE)
    (install / "helper.py").write_text("")
    (install / "numpy.py").write_text(SHADOW)
    (install / "colorsys.py").write_text(SHADOW)
    before = _files(install)
    for folder in (install, install.parent):        # read-only, as an installed package
        folder.chmod(stat.S_IRUSR | stat.S_IXUSR | stat.S_IRGRP | stat.S_IXGRP)
    try:
        r = esair("run", str(install), "--run", "1", "-e", free_endpoint(), cwd=run,
                  check=False)
    finally:
        for folder in (install.parent, install):
            folder.chmod(stat.S_IRWXU)
    assert r.returncode == 0, r.stderr
    where = json.loads((run / "out" / "where.json").read_text())
    assert where["cwd"] == str(run)
    assert where["ndarray"] is True
    assert not where["numpy"].startswith(str(install))
    assert not where["colorsys"].startswith(str(install))
    assert where["helper"] == str(install / "helper.py")
    assert _files(install) == before
