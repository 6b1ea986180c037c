"""STARFISH's robot side holds no pydantic (issue 37 item 2; docs/std-starfish.md): as
``esair std run`` runs the example, its driver and its ``turn_and_shoot`` behavior take
the board files' facts as plain data prepared where the deployment is checked — also
through a whole shot (the turn's profile, its slow start, the stop's plan) — in the
one process of thread mode and in every process of process mode (the modules a behavior
sees, and the shared objects mapped into each process). The limits they carry are the
board model's, and a bad robot file fails the behavior with its name."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from tests.support.std import MODES, ROOT, ask, components, free_endpoint, std_run, wait_for

pytestmark = [pytest.mark.pty, pytest.mark.slow]

EXAMPLE = ROOT / "esair_std" / "examples" / "starfish"
#: pydantic's compiled core: mapped into a process that imported pydantic
PYDANTIC_LIB = "_pydantic_core"


def _deployment(folder: Path, store: Path) -> Path:
    for name in ("starfish_behaviors.py", "room.yaml"):
        shutil.copy(EXAMPLE / name, folder)
    text = (EXAMPLE / "starfish.yaml").read_text()
    text = text.replace("store: starfish-pictures", f"store: {store}")
    text = text.replace("behaviors:\n", "behaviors:\n  checker:\n"
                        "    class: tests.support.lean_comps:CheckerModules\n", 1)
    dep = folder / "starfish.yaml"
    dep.write_text(text)
    return dep


def _started(ep: str) -> bool:
    rows = components(ep)
    ping = ask(ep, "ping")
    names = {r["name"] for r in rows}
    return ({"turn_and_shoot", "patrol", "localize", "checker"} <= names
            and all(r["state"] in ("running", "ready") for r in rows)
            and isinstance(ping, dict) and ping.get("starting") is False)


def _shot(ep: str):
    got = ask(ep, "get", {"to": "turn_and_shoot", "timeout": 5.0})
    return got["data"] if got and got.get("ok") and got["data"]["shots"] else None


@pytest.mark.parametrize("mode", MODES)
def test_the_starfish_robot_side_imports_no_pydantic_through_a_shot(mode, tmp_path,
                                                                     monkeypatch):
    monkeypatch.setenv("ESAIR_STD_CACHE", str(tmp_path / "cache"))
    store = tmp_path / "pictures"
    dep = _deployment(tmp_path, store)
    ep = free_endpoint()
    with std_run(str(dep), mode, ep, lambda: _started(ep)) as proc:
        ask(ep, "configure", {"resource": "starfish.mics", "key": "source",
                              "value": {"x": 1.0, "y": 3.5, "on": True}})
        shot = wait_for(lambda: _shot(ep), 60, "a picture")
        checker = ask(ep, "get", {"to": "checker", "timeout": 5.0})
        pids = {r["name"]: r["pid"] for r in components(ep)}
        maps = {name: Path(f"/proc/{pid}/maps").read_text().count(PYDANTIC_LIB)
                for name, pid in pids.items() | {("runtime", proc.pid)}}
    assert shot["aborted"] == 0 and shot["last"]["turn"]["max_w"] == 3000, shot
    assert json.loads((store / "starfish-00001.json").read_text()) == shot["last"]
    # of the checker's modules only yaml: the room file the driver and reconnect read
    assert checker["ok"] and set(checker["data"]) <= {"yaml"}, checker
    if mode == "process":       # turn_and_shoot and the driver in agents of their own
        assert pids["turn_and_shoot"] != proc.pid and pids["starfish"] != proc.pid
    assert maps == {name: 0 for name in maps}


def test_the_plain_limits_are_the_board_models(tmp_path):
    """The behavior's prepared facts give the same turn as the board model itself."""
    from esair_min.model.validate import load_robot
    from esair_min.resources import resolve_robot
    from esair_std.drivers.starfish import turn
    from esair_std.drivers.starfish.omniboard import OmniBoard
    from esair_std.examples.starfish.starfish_behaviors import TurnAndShoot
    prepared = TurnAndShoot.prepare_entry({}, str(tmp_path), "turn_and_shoot")
    plain = OmniBoard.from_json(json.loads(json.dumps(prepared["omni"])))
    model = load_robot(resolve_robot("starfish"))
    assert turn.turn_limits(plain) == turn.turn_limits(model) == (3.0, 2000 / 120)
    assert turn.flow_limit(plain) == turn.flow_limit(model)
    assert turn.start_plan(plain, (0.0, 200.0), 1.0, 3.0, 0.75 * turn.flow_limit(plain)[0],
                           0.03) == turn.start_plan(model, (0.0, 200.0), 1.0, 3.0,
                                                    0.75 * turn.flow_limit(model)[0], 0.03)
    a, b = turn.WheelRamp(plain, (150.0, 50.0), -1.0), turn.WheelRamp(model, (150.0, 50.0), -1.0)
    for m in (a, b):
        m.command(0.0, 3.0)
        m.command(0.3, 0.0)
    assert [a.at(t / 10) for t in range(8)] == [b.at(t / 10) for t in range(8)]
    assert any(str(f).endswith("drive.yaml") for f in prepared["inputs"])


@pytest.mark.parametrize("robot, says", [
    ("no-such-robot", "robot 'no-such-robot': no-such-robot: no such file or folder"),
    ("bad", "robot 'bad': {bad}/central.yaml:2:"),          # its file:line
    ("papaman", "robot 'papaman' has no omni base"),
])
def test_a_bad_robot_file_is_named(tmp_path, robot, says):
    from esair_std.examples.starfish.starfish_behaviors import TurnAndShoot
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "central.yaml").write_text("name: x\n  bad: [\n")
    with pytest.raises(ValueError) as exc:
        TurnAndShoot.prepare_entry({"robot": robot}, str(tmp_path), "turn_and_shoot")
    assert says.format(bad=tmp_path / "bad") in str(exc.value)
