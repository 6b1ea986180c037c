"""The HMI tells the truth (issue 34 item 2), against `esair std run papaman --hmi` in a
real headless chromium, both modes: a refused slider goes back to the robot's angle with
the reason beside it, one log line per refused command, an HMI started after the robot
moved shows the pose the robot holds, the behaviors' states are readable fields, and the
page fits a phone (390 px) and a 1280x800 window. (A refused STOP's log line:
test_hmi_refusals.py.)"""

from __future__ import annotations

import pytest
from playwright.sync_api import TimeoutError as PlaywrightTimeout

from esair_min.model.validate import load_robot
from esair_std.hmi.child import HmiChild
from tests.support.hmi import PAPAMAN, log_in, open_page

LOG_LINES = "() => [...document.querySelectorAll('#log li')].map(li => li.textContent)"
ANGLES = "() => window.__hmi.pose.angles"


@pytest.fixture(scope="module")
def papaman():
    return load_robot(PAPAMAN)


def test_a_refused_slider_goes_back_to_the_robots_angle_with_the_reason(robot, browser):
    """An angle past the servo's limits (the slider's range widened by hand: the driver
    refuses it, nothing is sent) puts the slider and its number back at the robot's angle,
    the reason beside it, and the log says it once; the next command that goes through
    clears the reason."""
    page, errors = open_page(browser, robot.url)
    slider = page.locator("#joints input[data-servo=r_knee]")
    held = slider.input_value()
    slider.evaluate("e => { e.max = 400; }")
    slider.fill("400")                              # input + change: sent on release
    why = page.locator("#joints label:has(input[data-servo=r_knee]) .why")
    why.wait_for(state="visible")
    assert "outside its limits" in why.inner_text(), why.inner_text()
    page.wait_for_function(f"() => document.querySelector('#joints input[data-servo=r_knee]')"
                           f".value === '{held}'")
    out = page.locator("#joints label:has(input[data-servo=r_knee]) output").inner_text()
    assert out == f"{held}°"
    lines = [ln for ln in page.evaluate(LOG_LINES) if '"angle":400' in ln or "'angle': 400" in ln
             or '"angle": 400' in ln]
    assert len(lines) == 1 and "refused" in lines[0], lines
    assert lines[0].count("papaman.servo.r_knee") == 1 and "outside its limits" in lines[0], lines
    slider.fill("95")                               # went through: the reason goes
    page.wait_for_function("() => document.querySelector("
                           "'#joints label:has(input[data-servo=r_knee]) .why').hidden")
    page.close()
    assert errors == []


def test_an_hmi_started_after_the_robot_moved_shows_the_pose_it_holds(robot, browser, papaman):
    """A dance played to its end, STOP and release, a knee commanded by another sender: a second HMI
    started then shows the dance's last frame with that knee (the actuators' last commands,
    from the runtime), not every joint at its default."""
    page, errors = open_page(browser, robot.url)
    page.click("#motions button[data-motion=dance]")
    page.wait_for_function("() => { const h = window.__hmi, p = h.played; return p && "
                           "p.v.play === 'dance' && !p.stopped && h.pose.motion === null; }",
                           timeout=30000)
    assert page.evaluate("() => window.__hmi.send({op: 'stop'})")["ok"]
    assert page.evaluate("() => window.__hmi.send({op: 'release'})")["ok"]  # the latch
    robot.send("papaman.servo.l_knee", {"angle": 77})       # another sender's
    page.wait_for_function("() => window.__hmi.pose.angles.l_knee === 77")
    names = [s.name for s in papaman.servos]
    want = dict(zip(names, papaman.motion("dance").frames[-1].angles, strict=True), l_knee=77)
    assert page.evaluate(ANGLES) == want
    page.close()
    second = HmiChild(robot.endpoint, "127.0.0.1:0")
    url = second.start()
    try:
        later, more = open_page(browser, url, login=False)
        later.wait_for_function("() => window.__hmi.pose.angles.l_knee === 77")
        assert later.evaluate(ANGLES) == want
        assert later.evaluate("() => document.querySelector("
                              "'#joints input[data-servo=l_knee]').value") == "77"
        later.close()
    finally:
        second.stop()
    assert errors == more == []


def test_the_behaviors_states_are_readable_fields(robot, browser):
    """Each behavior's state is one row a field (a list as its items or its count and
    last item), never raw JSON cut mid-line."""
    page, errors = open_page(browser, robot.url)
    page.wait_for_function("() => ['sequencer', 'watcher', 'logger'].every(n => "
                           "document.querySelector(`[data-state=${n}] dl.fields dt`))")
    got = page.evaluate("""() => Object.entries(window.__hmi.generic.states).map(([n, st]) => [n,
        Object.keys(st.value),
        [...st.list.querySelectorAll('dt')].map(e => e.textContent),
        [...st.list.querySelectorAll('dd')].map(e => e.textContent)])""")
    assert sorted(n for n, *_ in got) == ["logger", "sequencer", "watcher"]
    for name, keys, dts, dds in got:
        # every key of the state has its row (an object's keys one level down)
        assert all(k in dts or any(d.startswith(k + ".") for d in dts) for k in keys), (name, dts)
        assert len(dts) == len(dds)
        for dd in dds:
            assert len(dd) <= 60 and "{" not in dd and "[" not in dd, (name, dd)
    seq = dict(zip(*next((d, v) for n, _, d, v in got if n == "sequencer"), strict=True))
    assert seq["queued"] == "none", seq              # an empty list: "none", not "[]"
    assert page.locator("#states pre").count() == 0
    page.close()
    assert errors == []


COVERED = """() => {
  const out = [];
  for (const h of document.querySelectorAll('main h2')) {
    if (!h.offsetParent) continue;                       // a hidden panel's
    for (const block of ['end', 'center']) {
      h.scrollIntoView({block});
      const r = h.getBoundingClientRect(), y = r.top + r.height / 2;
      for (const x of [r.left + 4, (r.left + r.right) / 2, r.right - 4]) {
        const e = document.elementFromPoint(x, y);
        if (!e || !(h === e || h.contains(e) || e.contains(h) && e.tagName === 'SECTION'))
          out.push(`${h.textContent.trim().slice(0, 12)} (${block}) under ${e && (e.id || e.tagName)}`);
      }
    }
  }
  window.scrollTo(0, 0);
  return out; }"""


def test_on_a_phone_the_header_is_one_row_and_stop_covers_no_heading(robot, browser):
    """390 px wide: the header is one row (the links scroll sideways) with STOP in it,
    always in view; no heading, scrolled to the bottom or the middle of the screen, lies
    under STOP or the header; the components table fits, as name and state."""
    page, errors = open_page(browser, robot.url, login=False, width=390, height=844)
    assert page.locator("#login").is_visible()            # a viewer: the login form in the row too
    one_row(page)
    log_in(page)                                          # an operator: STOP in the row
    page.wait_for_function("() => document.querySelectorAll('#components tbody tr').length > 10")
    assert page.evaluate(COVERED) == []
    one_row(page)
    page.evaluate("() => window.scrollTo(0, document.body.scrollHeight)")
    box = page.locator("#stop").bounding_box()
    assert box is not None and box["y"] >= 0 and box["y"] + box["height"] <= 844
    assert page.locator("#stop").is_visible()
    table = page.evaluate("""() => { const t = document.querySelector('#components'),
        s = t.parentElement;
        return [t.scrollWidth, s.clientWidth,
          [...t.querySelectorAll('thead th')].filter(th => th.offsetParent).map(th => th.textContent)]; }""")
    assert table[0] <= table[1] and table[2] == ["name", "state", ""], table
    page.close()
    assert errors == []


def one_row(page) -> None:
    """The header's visible parts share one row, nothing in it overflows."""
    rows = page.evaluate("""() => [...document.querySelectorAll('header#top > *')]
        .filter(e => e.offsetParent).map(e => { const r = e.getBoundingClientRect();
          return [e.id || e.className, Math.round(r.top), Math.round(r.bottom)]; })""")
    header = page.evaluate("() => { const h = document.querySelector('header#top'); "
                           "return [h.getBoundingClientRect().height, h.scrollWidth, h.clientWidth]; }")
    assert header[0] < 60 and header[1] <= header[2], (header, rows)
    mids = {(top + bottom) // 2 for _, top, bottom in rows}
    assert max(mids) - min(mids) <= 4, rows


def test_at_1280x800_the_components_and_the_log_are_in_the_window(robot, browser):
    """1280x800: the page does not grow past the window; the components table and the log
    are in it, each scrolling in its panel (the last component reachable)."""
    page, errors = open_page(browser, robot.url)
    page.wait_for_function("() => document.querySelectorAll('#components tbody tr').length > 10")
    assert page.evaluate("() => document.documentElement.scrollHeight") <= 800
    for sel in ("#components-panel", "#log-panel", "#pose-panel", "#joints-panel", "#feet-panel"):
        box = page.locator(sel).bounding_box()
        assert box is not None and box["y"] >= 0 and box["y"] + box["height"] <= 800, (sel, box)
        assert box["height"] >= 100, (sel, box)
    last = page.evaluate("""() => { const s = document.querySelector('#components-panel .scroll');
        s.scrollTop = s.scrollHeight;
        const tr = [...s.querySelectorAll('tbody tr')].pop(), a = tr.getBoundingClientRect(),
          b = s.getBoundingClientRect();
        return [s.scrollHeight > s.clientHeight, a.top >= b.top - 1 && a.bottom <= b.bottom + 1]; }""")
    assert last == [True, True], last
    # all twelve joints and both feet plots are in view without scrolling their panels
    page.wait_for_function("() => window.__hmi.feet.t.length > 2")
    joints = page.locator("#joints-panel")
    assert joints.evaluate("e => e.scrollHeight <= e.clientHeight + 1")
    page.close()
    assert errors == []


def test_the_banners_stick_right_under_the_header_whatever_its_height(robot, browser):
    """At 760 px the header wraps (taller than the 46 px a banner stuck at before): a
    banner (link lost, STOPPED) scrolled with the page sticks right under it, not under
    its first row."""
    page, errors = open_page(browser, robot.url, width=760, height=700)
    # the link pill's text changes 4 times a second and may wrap the header anew: the
    # banner follows within a frame, so each is waited for, not read once
    where = """id => { const h = document.querySelector('header#top').getBoundingClientRect(),
        b = document.getElementById(id).getBoundingClientRect();
        return [Math.round(h.bottom), Math.round(b.top)]; }"""
    # each shown as the page shows it (the link bar's updates would hide a banner shown
    # by hand): the runtime said lost, a STOP told (the page only; nothing is sent)
    show = {"banner": "() => { const h = window.__hmi; h.runtimeUp = false; h.banner(); }",
            "latch": "() => window.__hmi.latched({stopped: true, by: 'the test', at: 'now'})"}
    for name, how in show.items():
        if page.locator(f"#{name}").count() == 0:
            continue
        page.evaluate(how)
        page.evaluate("() => window.scrollTo(0, 600)")
        ok = True
        try:
            page.wait_for_function(f"id => {{ const [h, top] = ({where})(id); "
                                   "return h > 50 && Math.abs(h - top) <= 1; }", arg=name,
                                   timeout=5000)
        except PlaywrightTimeout:
            ok = False
        assert ok, f"{name}: header bottom, banner top: {page.evaluate(where, name)}"
        page.evaluate("id => { document.getElementById(id).hidden = true; "
                      "window.__hmi.runtimeUp = true; window.scrollTo(0, 0); }", name)
    page.close()
    assert errors == []
