"""``esair std run``'s robot side holds no pydantic (issue 37 item 2, docs/std.md "A
robot side without pydantic"): the deployment is checked in a short-lived child (or
taken from the cache) and handed over as plain data. Checked on PAPA-MAN's deployment
(its MinLink driver's options and board model included), in both modes, in every
process of the robot side: the runtime (the one process in thread mode), the zygote
and every agent in process mode — by the modules a behavior of the robot side sees,
and by the shared objects mapped into each process (/proc/PID/maps)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.support.std import MODES, ROOT, ask, components, free_endpoint, processes, std_run

pytestmark = [pytest.mark.pty, pytest.mark.slow]

PAPAMAN = ROOT / "esair_std" / "examples" / "papaman"
#: the checker's compiled libraries: pydantic's core, libyaml's binding, Jinja2's markupsafe
CHECKER_LIBS = ("_pydantic_core", "yaml/_yaml", "markupsafe/")


def _deployment(folder: Path, feet_hz: int = 8) -> Path:
    shutil.copy(PAPAMAN / "papaman_behaviors.py", folder)
    text = (PAPAMAN / "papaman.yaml").read_text().replace("feet_hz: 8", f"feet_hz: {feet_hz}")
    text += ("  checker:\n    class: tests.support.lean_comps:CheckerModules\n")
    dep = folder / "dep.yaml"
    dep.write_text(text)
    return dep


def _libs(pid: int) -> list[str]:
    maps = Path(f"/proc/{pid}/maps").read_text()
    return sorted({lib for lib in CHECKER_LIBS if lib in maps})


def _started(ep: str) -> bool:
    rows = components(ep)
    ping = ask(ep, "ping")
    return (len(rows) > 5 and all(r["state"] in ("running", "ready") for r in rows)
            and isinstance(ping, dict) and ping.get("starting") is False)


@pytest.fixture
def cache(tmp_path, monkeypatch):
    folder = tmp_path / "cache"
    monkeypatch.setenv("ESAIR_STD_CACHE", str(folder))
    return folder


@pytest.mark.parametrize("mode", MODES)
def test_the_robot_side_imports_no_checker(mode, tmp_path, cache):
    dep = _deployment(tmp_path)
    ep = free_endpoint()
    with std_run(str(dep), mode, ep, lambda: _started(ep)) as proc:
        got = ask(ep, "get", {"to": "checker", "timeout": 5.0})
        pids = {r["name"]: r["pid"] for r in components(ep)}
        zygotes = [pid for pid, ppid, cmd in processes()
                   if ppid == proc.pid and b"esair_std.hosts.zygote" in cmd]
        libs = {pid: _libs(pid) for pid in {proc.pid, *pids.values(), *zygotes}}
    assert got["ok"], got
    assert got["data"] == []                       # the behavior's process: no module of them
    if mode == "thread":
        assert set(pids.values()) == {proc.pid}
    else:
        assert len(zygotes) == 1 and len(set(pids.values())) == 5   # runtime, 4 agents
        assert pids["papaman.feet"] != proc.pid     # the driver in an agent of its own
    assert libs == {pid: [] for pid in libs}
    assert list(cache.glob("*.json")), "the checked deployment was kept"


def test_the_check_can_fail(tmp_path, cache):
    """The same checks see the checker where it is loaded: a Runtime of the Python API
    checks its deployment in its own process."""
    dep = _deployment(tmp_path)
    code = ("import os, sys; from esair_std import Runtime\n"
            "from tests.support import lean_comps\n"
            f"rt = Runtime({str(dep)!r}, control=False)\n"
            "print(' '.join(m for m in lean_comps.CHECKER if m in sys.modules))\n"
            "print(open('/proc/self/maps').read().count('_pydantic_core'))\n")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                         text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    mods, maps = out.stdout.splitlines()
    assert {"pydantic", "yaml", "esair_std.deploy.model"} <= set(mods.split())
    assert int(maps) > 0


CHECK_TWICE = """
import json, sys
from esair_std.lean import checked
from esair_std.deploy.overrides import set_port
hows, deps = [], []
for _ in range(int(sys.argv[2])):
    d = checked.checked_deployment(sys.argv[1], {"port": None, "emulate": {}})
    hows.append(checked.last["how"])
    deps.append(d.to_json() if d is not None else None)
print(json.dumps({"hows": hows, "deps": deps}))
"""


def _check(dep: Path, times: int = 1) -> dict:
    out = subprocess.run([sys.executable, "-c", CHECK_TWICE, str(dep), str(times)], cwd=ROOT,
                         capture_output=True, text=True, timeout=120,
                         env=dict(os.environ))
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


def test_a_cache_hit_and_a_miss_give_the_same_robot(tmp_path, cache):
    dep = _deployment(tmp_path)
    got = _check(dep, 2)
    assert got["hows"] == ["checked", "cache"]
    assert got["deps"][0] == got["deps"][1]
    specs = {s["name"]: s for s in got["deps"][0]["specs"]}
    driver = specs["papaman"]["prepared"]
    assert driver["options"]["feet_hz"] == 8
    assert [s["name"] for s in driver["board"]["servos"]][:2] == ["l_hip_yaw", "l_hip_roll"]
    # as the Python API reads the same file (in its own process, pydantic and all)
    from esair_std.deploy import load_deployment
    from esair_std.spec import specs_of
    res, beh, rea = specs_of(load_deployment(dep))
    assert [s.to_json() | {"prepared": None} for s in res + rea + beh] == [
        s | {"prepared": None} for s in got["deps"][0]["specs"]]
    # a file it was made from changes: made again, with the change
    _deployment(tmp_path, feet_hz=4)
    again = _check(dep)
    assert again["hows"] == ["checked"]
    assert {s["name"]: s for s in again["deps"][0]["specs"]}[
        "papaman"]["prepared"]["options"]["feet_hz"] == 4
    # a damaged cache: made again, as if there were none
    for f in cache.glob("*.json"):
        f.write_text('{"deployment": {"format": 1, "rob')
    assert _check(dep)["hows"] == ["checked"]
    assert _check(dep)["hows"] == ["cache"]


def test_a_folder_that_cannot_be_written_is_no_cache(tmp_path, monkeypatch):
    dep = _deployment(tmp_path)
    blocked = tmp_path / "file"
    blocked.write_text("not a folder")
    monkeypatch.setenv("ESAIR_STD_CACHE", str(blocked / "cache"))
    assert _check(dep, 2)["hows"] == ["checked", "checked"]


@pytest.mark.parametrize("old, new, at", [
    ("feet_hz: 8 ", "feet_hz: fast ", ":19:14"),                  # a driver's option
    ("papaman_behaviors:Sequencer", "papaman_behaviors:Sequencr", ":25:12"),   # a class
])
def test_a_bad_deployment_says_where_as_before(tmp_path, cache, old, new, at):
    dep = _deployment(tmp_path)
    dep.write_text(dep.read_text().replace(old, new, 1))
    run = subprocess.run([sys.executable, "-m", "esair_min.cli", "std", "run", str(dep),
                          "--run", "1", "-e", free_endpoint()], cwd=ROOT, capture_output=True,
                         text=True, timeout=120)
    check = subprocess.run([sys.executable, "-m", "esair_min.cli", "std", "check", str(dep)],
                           cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert run.returncode == 1 and check.returncode == 1
    assert f"{dep}{at}" in run.stderr, run.stderr
    assert "Traceback" not in run.stderr
    first = run.stderr.strip().splitlines()[0]
    assert first in check.stdout + check.stderr
    assert not list(cache.glob("*.json"))


def test_a_start_from_the_cache_runs_the_robot_a_check_ran(tmp_path, cache):
    """Two `esair std run --run` of one deployment: the first checks it and keeps it, the
    second reads it (the entry is not written again) and runs the same components."""
    dep = _deployment(tmp_path)

    def run() -> list[tuple[str, ...]]:
        out = subprocess.run([sys.executable, "-m", "esair_min.cli", "std", "run", str(dep),
                              "--run", "2", "-e", free_endpoint()], cwd=ROOT,
                             capture_output=True, text=True, timeout=120,
                             env=dict(os.environ, COLUMNS="200"))
        assert out.returncode == 0, out.stderr
        rows = [line.split()[:3] for line in out.stdout.splitlines()[1:] if line.strip()]
        return sorted(tuple(r) for r in rows)

    first = run()
    [entry] = cache.glob("*.json")
    written = entry.stat().st_mtime_ns
    second = run()
    assert entry.stat().st_mtime_ns == written            # read, not made again
    assert first == second and len(first) == 19     # 15 resources, 4 behaviors
    assert ("papaman.feet", "sensor", "ready") in first and ("checker", "behavior", "running") in first
