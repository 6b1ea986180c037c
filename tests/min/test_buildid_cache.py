"""The build id kept on disk (codegen/buildid.py): what is read back is what the
rendering gives, and another robot or another generator is another key."""

from __future__ import annotations

from esair_min.codegen import buildid
from esair_min.codegen.buildid import central_build_id


def test_a_kept_build_id_is_the_rendered_one_and_any_change_renders_again(
        robot, fast_robot, tmp_path, monkeypatch):
    monkeypatch.setenv("ESAIR_CACHE", str(tmp_path))
    monkeypatch.setattr(buildid, "_CACHE", {})
    kept = tmp_path / "build-id"
    first = central_build_id(robot)
    assert first == buildid._render_id(robot)
    [entry] = kept.iterdir()
    assert entry.read_text() == first
    # a new process reads it: what the file holds is taken, nothing is rendered
    entry.write_text("0badc0de")
    buildid._CACHE.clear()
    assert central_build_id(robot) == "0badc0de"
    # a damaged file is rendered again and replaced
    entry.write_text("not an id")
    buildid._CACHE.clear()
    assert central_build_id(robot) == first and entry.read_text() == first
    # another robot (its UART at another baud) is another key, rendered
    other = central_build_id(fast_robot)
    assert other == buildid._render_id(fast_robot) != first
    assert len(list(kept.iterdir())) == 2
    # another generator (any file of the package or the templates) is another key
    monkeypatch.setattr(buildid, "_sources_digest", b"another generator")
    buildid._CACHE.clear()
    assert central_build_id(robot) == first
    assert len(list(kept.iterdir())) == 3


def test_an_unwritable_cache_only_costs_the_rendering(robot, tmp_path, monkeypatch):
    (tmp_path / "file").write_text("")
    monkeypatch.setenv("ESAIR_CACHE", str(tmp_path / "file"))    # not a folder
    monkeypatch.setattr(buildid, "_CACHE", {})
    assert central_build_id(robot) == buildid._render_id(robot)
