"""STARFISH on the remote control center through the GENERIC panels (docs/hmi.md,
docs/std-starfish.md): ``esair std run starfish --hmi`` (the emulated boards on the MIN
link, the room of the example) in a real headless chromium. The map panel draws the
room's walls and landmarks from ``starfish.map`` and the robot from the odometry; the
last picture the camera took shows from ``starfish.pictures`` (also on a page opened
later); localize's bearing shows on a dial and as a ray on the map that points at the
sound source. No STARFISH code in the page: the panels come from the samples' shapes."""

from __future__ import annotations

import base64
import json
import math
import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from esair_std.drivers.starfish.scene import load_scene
from tests.support.hmi import ROOT, esair_std, free_port, wait_for

ROOM = ROOT / "esair_std" / "examples" / "starfish" / "room.yaml"
MAP = "window.__hmi.generic.maps.starfish"


class StarfishHmi:
    """``esair std run starfish --hmi`` (the bundled example, its own emulated boards)."""

    def __init__(self, mode: str, tmp: Path):
        self.mode, self.tmp = mode, tmp
        self.endpoint = f"tcp/127.0.0.1:{free_port()}"
        self.proc: subprocess.Popen | None = None

    def start(self) -> "StarfishHmi":
        env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
        env.pop("ESAIR_HMI_PASSWORD", None)            # on 127.0.0.1: every page an operator
        self.errors = open(self.tmp / "run.err", "w+")      # noqa: SIM115 - closed in stop()
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "esair_min.cli", "std", "run", "starfish", "--hmi",
             "--hmi-listen", "127.0.0.1:0", "--mode", self.mode, "-e", self.endpoint, "--no-top"],
            stdout=subprocess.DEVNULL, stderr=self.errors, env=env, cwd=self.tmp)

        def url():
            if self.proc.poll() is not None:
                raise AssertionError(f"esair std run exited: {(self.tmp / 'run.err').read_text()}")
            m = re.search(r"^hmi: (http://\S+)$", (self.tmp / "run.err").read_text(), re.M)
            return m and m.group(1)
        self.url = wait_for(url, timeout=90, what="the HMI's URL")
        return self

    def std(self, *args: str) -> str:
        r = esair_std(*args, "-e", self.endpoint)
        assert r.returncode == 0, r.stderr
        return r.stdout

    def get(self, name: str) -> dict:
        return json.loads(self.std("get", name))

    def stop(self) -> None:
        if self.proc is not None:
            self.proc.send_signal(signal.SIGTERM)
            self.proc.wait(timeout=30)
            self.errors.close()


@pytest.fixture(scope="module")
def starfish_hmi(tmp_path_factory):
    # thread mode: what `esair std run starfish --hmi` gives a newcomer (the HMI's watch
    # in both modes is tested with PAPA-MAN, tests/hmi/test_hmi_papaman.py)
    r = StarfishHmi("thread", tmp_path_factory.mktemp("hmi-starfish"))
    try:
        yield r.start()
    finally:
        r.stop()
    assert r.proc.returncode == 0, (r.tmp / "run.err").read_text()


def open_page(browser, url: str):
    page = browser.new_page(viewport={"width": 1280, "height": 900})
    errors: list[str] = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto(url)
    page.wait_for_function("() => window.__hmi && window.__hmi.wsUp && window.__hmi.generic")
    return page, errors


def test_the_map_panel_draws_the_room_and_the_robot_driving_in_it(starfish_hmi, browser):
    page, errors = open_page(browser, starfish_hmi.url)
    room = load_scene(ROOM)
    page.wait_for_function(f"() => {MAP} && {MAP}.view.walls > 0 && {MAP}.view.pose")
    walls = page.evaluate(f"() => {MAP}.walls")
    assert walls == [[round(float(v), 4) for v in w] for w in room.walls]
    assert len(walls) == 5                      # the box's 4 sides and the inner wall
    kinds = sorted(lm["kind"] for lm in page.evaluate(f"() => {MAP}.landmarks"))
    assert kinds == ["access_point", "pole", "pole", "pole", "sound"]
    # the robot on it is the odometry's, and it moves (patrol drives it)
    assert page.evaluate(f"() => {MAP}.pose.r") == "starfish.odometry"
    first = page.evaluate(f"() => {MAP}.view.pose")
    x0, y0, x1, y1 = room.bounds()
    assert x0 < first[0] < x1 and y0 < first[1] < y1
    page.wait_for_function(f"""() => {{ const p = {MAP}.view.pose;
        return Math.hypot(p[0] - {first[0]}, p[1] - {first[1]}) > 0.2; }}""", timeout=30000)
    # the map is the only panel of the two sensors: no plot of x, y or of the walls
    panels = page.evaluate("() => Object.keys(window.__hmi.generic.panels)")
    assert "starfish.odometry" not in panels and "starfish.map" not in panels
    assert page.locator("[data-map=starfish] canvas").is_visible()
    assert page.locator("#pose-panel").is_hidden()      # no servos: no stick figure
    page.close()
    assert errors == []


def picture_src(page) -> str | None:
    return page.evaluate("() => { const p = window.__hmi.generic.panels['starfish.pictures'];"
                         " return p ? p.img.src : null; }")


def stored_picture(hmi: StarfishHmi) -> str | None:
    last = hmi.get("turn_and_shoot")["last"]
    if not last:
        return None
    data = (Path(hmi.get("turn_and_shoot")["store"]) / last["file"]).read_bytes()
    return f"data:image/png;base64,{base64.b64encode(data).decode()}"


def test_the_last_picture_shows_on_the_picture_panel_also_on_a_page_opened_later(
        starfish_hmi, browser):
    page, errors = open_page(browser, starfish_hmi.url)
    starfish_hmi.std("configure", "starfish.mics", "source", '{"x": 1.0, "y": 3.5, "on": true}')
    # sound -> localize -> turn_and_shoot turns and shoots: the picture it stored is the
    # one the page shows (byte for byte)
    wait_for(lambda: stored_picture(starfish_hmi) is not None, timeout=60, what="a picture stored")

    def same():
        want = stored_picture(starfish_hmi)
        return want is not None and picture_src(page) == want and want
    want = wait_for(same, timeout=20, what="the page's picture == the stored picture")
    page.wait_for_function("() => { const i = window.__hmi.generic.panels['starfish.pictures'].img;"
                           " return i.complete && i.naturalWidth === 320 && i.naturalHeight === 240; }")
    # a page opened now gets the last picture at once (the HMI keeps each sensor's last
    # sample), not only with the next shot (turn_and_shoot waits 5 s between shots)
    later, errors2 = open_page(browser, starfish_hmi.url)
    later.wait_for_function("() => window.__hmi.generic.panels['starfish.pictures']")
    assert picture_src(later) in (want, stored_picture(starfish_hmi))
    later.close()
    page.close()
    assert errors == [] and errors2 == []


def test_localize_bearing_shows_on_a_dial_and_points_at_the_source_on_the_map(
        starfish_hmi, browser):
    hmi = starfish_hmi
    # turn_and_shoot would turn the robot to face the sound (a bearing near 0 tells little):
    # without it patrol keeps its heading and the bearing stays large
    if "turn_and_shoot" in hmi.std("ls"):
        hmi.std("remove", "turn_and_shoot")
    page, errors = open_page(browser, hmi.url)
    page.wait_for_function(f"() => {MAP} && {MAP}.view.pose")
    x, y, th = page.evaluate(f"() => {MAP}.view.pose")
    # the source 1.5 m to the robot's side (left or right: whichever stays in the room)
    room = load_scene(ROOM)
    x0, y0, x1, y1 = room.bounds()
    for side in (1, -1):
        sx, sy = x + 1.5 * math.cos(th + side * math.pi / 2), y + 1.5 * math.sin(th + side * math.pi / 2)
        if x0 + 0.3 < sx < x1 - 0.3 and y0 + 0.3 < sy < y1 - 0.3:
            break
    hmi.std("configure", "starfish.mics", "source", json.dumps({"x": sx, "y": sy, "on": True}))
    page.wait_for_function(f"""() => {MAP}.landmarks.some(l => l.kind === 'sound' && l.on &&
        Math.abs(l.x - {sx}) < 1e-3 && Math.abs(l.y - {sy}) < 1e-3)""", timeout=10000)
    # the ray (the odometry's heading + localize's bearing) points at the source from the
    # robot on the map, while the bearing is far from 0 (a sign or frame error would not)
    page.wait_for_function(f"""() => {{
        const m = {MAP}, st = window.__hmi.generic.states.localize;
        if (!st || !st.bearing || !m.view.ray || !m.view.pose) return false;
        if (st.bearing.confidence < 0.3 || Math.abs(st.bearing.bearing) < 0.6) return false;
        const src = m.landmarks.find(l => l.kind === 'sound');
        const want = Math.atan2(src.y - m.view.pose[1], src.x - m.view.pose[0]);
        const d = Math.atan2(Math.sin(m.view.ray - want), Math.cos(m.view.ray - want));
        return Math.abs(d) < 10 * Math.PI / 180; }}""", timeout=40000)
    text = page.locator("[data-state=localize] .bearing").inner_text()
    assert re.fullmatch(r"bearing -?\d+\.\d° · confidence \d\.\d\d", text), text
    assert page.locator("[data-state=localize] canvas").is_visible()
    page.close()
    assert errors == []
