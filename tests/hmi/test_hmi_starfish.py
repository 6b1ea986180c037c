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
import re
from pathlib import Path

import numpy as np
import pytest

from esair_std.drivers.starfish.scene import load_scene
from tests.support.hmi import wait_for
from tests.support.starfish_hmi import MAP, ROOM, StarfishHmi, open_page


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
    state = hmi.get("turn_and_shoot")
    if not state["last"]:
        return None
    data = (Path(state["store"]) / state["last"]["file"]).read_bytes()
    return f"data:image/png;base64,{base64.b64encode(data).decode()}"


def test_the_last_picture_shows_on_the_picture_panel_also_on_a_page_opened_later(
        starfish_hmi, browser):
    page, errors = open_page(browser, starfish_hmi.url)
    starfish_hmi.configure("starfish.mics", "source", {"x": 1.0, "y": 3.5, "on": True})
    # sound -> localize -> turn_and_shoot turns and shoots: the picture it stored is the
    # one the page shows (byte for byte)
    page.wait_for_function("() => { const p = window.__hmi.generic.panels['starfish.pictures'];"
                           " return p && p.img.src.startsWith('data:image/png;base64,'); }",
                           timeout=60000)

    def same():
        want = stored_picture(starfish_hmi)
        return want is not None and picture_src(page) == want and want
    want = wait_for(same, timeout=20, what="the page's picture == the stored picture")
    page.wait_for_function("() => { const i = window.__hmi.generic.panels['starfish.pictures'].img;"
                           " return i.complete && i.naturalWidth === 320 && i.naturalHeight === 240; }")
    # silence: no more shots. A page opened now still gets the last picture (the HMI
    # keeps each sensor's last sample for a page's hello)
    starfish_hmi.configure("starfish.mics", "source", {"x": 1.0, "y": 3.5, "on": False})
    later, errors2 = open_page(browser, starfish_hmi.url)
    later.wait_for_function("() => { const p = window.__hmi.generic.panels['starfish.pictures'];"
                            " return p && p.img.src.startsWith('data:image/png;base64,'); }")
    assert picture_src(later) in (want, stored_picture(starfish_hmi))
    later.close()
    page.close()
    assert errors == [] and errors2 == []


def test_localize_bearing_shows_on_a_dial_and_points_at_the_source_on_the_map(
        starfish_hmi, browser):
    hmi = starfish_hmi
    # turn_and_shoot would turn the robot to face the sound (a bearing near 0 tells little):
    # without it patrol keeps its heading and the bearing stays large
    if "turn_and_shoot" in [row["name"] for row in hmi.call("ls", {"all": True})]:
        hmi.call("remove", {"name": "turn_and_shoot"}, timeout=30)
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
    hmi.configure("starfish.mics", "source", {"x": sx, "y": sy, "on": True})
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


MICS = "window.__hmi.generic.panels['starfish.mics']"


def test_the_serial_link_has_its_pill_and_the_mics_plot_their_levels(starfish_hmi, browser):
    """STARFISH's driver is a MinLink (derived from it): its serial link is on the link
    bar as PAPA-MAN's is. The microphones' frames are plotted as each channel's level
    (dBFS), with their rate as text, not as the frame's fields (t, seq, rate, n...)."""
    page, errors = open_page(browser, starfish_hmi.url)
    page.wait_for_function("() => { const l = window.__hmi.link.starfish; return l && l.state === 'ready'; }")
    page.wait_for_function(
        "() => document.querySelector('#linkbar').textContent.includes('starfish link ready')")
    page.wait_for_function(f"() => {MICS} && {MICS}.last")
    assert page.evaluate(f"() => {MICS}.u.series.slice(1).map(s => s.label)") == [
        "mic 1", "mic 2", "mic 3", "mic 4"]
    assert page.evaluate(f"() => [{MICS}.u.scales.y.min, {MICS}.u.scales.y.max]") == [-80, 0]
    # a frame's levels on the page are its channels' RMS, from its samples
    page.evaluate(f"""() => {{ const p = {MICS}, push = p.push.bind(p);
        p.push = (m) => {{ push(m); window.__frame = [m.v, p.last.levels]; }}; }}""")
    page.wait_for_function("() => window.__frame")
    frame, shown = page.evaluate("window.__frame")
    pcm = np.frombuffer(base64.b64decode(frame["pcm"]), "<i2").reshape(frame["n"], frame["channels"])
    rms = np.sqrt(np.mean(pcm.astype(float) ** 2, axis=0)) / 32768
    want = [max(-80.0, round(20 * math.log10(r), 1)) if r > 0 else -80.0 for r in rms]
    assert shown == pytest.approx(want, abs=0.051)
    page.wait_for_function(f"() => {MICS}.note.textContent.includes('frames/s')")
    note = page.evaluate(f"() => {MICS}.note.textContent")
    assert re.fullmatch(rf"{frame['rate']} Hz · 4 channels · {frame['n']} samples a frame · "
                        r"frame \d+ · \d+\.\d frames/s", note), note
    page.close()
    assert errors == []


def _hmi_commands(url: str) -> int:
    import urllib.request
    with urllib.request.urlopen(url + "status.json", timeout=5) as r:
        return json.load(r)["counters"]["commands"]


def test_an_actuators_command_box_takes_json_or_text_and_refuses_a_json_typo(
        starfish_hmi, browser):
    """An actuator with no panel of its own (STARFISH's camera) gets a command box that
    takes JSON or text as `esair std send` does: text that starts like JSON and does not
    parse is not sent (the box and the log say why); what is sent goes to the runtime like
    any command (here the deployment's allow refuses the HMI, and the log says so)."""
    page, errors = open_page(browser, starfish_hmi.url)
    form = page.locator("form.generic").filter(has_text="send to starfish.camera")
    form.wait_for()
    before = _hmi_commands(starfish_hmi.url)
    form.locator("input").fill('{"shoot": tru')
    form.locator("button").click()
    page.wait_for_function("() => document.querySelector('#log').textContent"
                           ".includes('starfish.camera: not sent: not JSON')")
    assert form.locator("input").evaluate("e => e.validationMessage").startswith("not JSON: ")
    assert _hmi_commands(starfish_hmi.url) == before            # nothing went out
    form.locator("input").fill("shoot")                         # text: sent as the string
    form.locator("button").click()
    wait_for(lambda: _hmi_commands(starfish_hmi.url) == before + 1, what="the command sent")
    assert form.locator("input").evaluate("e => e.validationMessage") == ""
    page.wait_for_function("() => [...document.querySelectorAll('#log li')].some(li => "
                           "li.textContent.includes('starfish.camera \"shoot\"'))")
    page.close()
    assert errors == []
