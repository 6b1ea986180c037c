"""The page's STOP is the runtime's latched STOP (issue 34 item 1; docs/hmi.md), in a
real headless chromium against ``esair std run papaman --hmi``, both modes, judged by
the emulated robot's own trace (the lines it received and its actuator writes): ten
dances queued, STOP clicked during one, then nothing moves until an operator's Release,
every page (one opened later too) shows who stopped it, a viewer cannot release, and a
STOP and a release racing from two pages leave the runtime, the robot and every page
agreeing."""

from __future__ import annotations

import re

import pytest

from esair_std.drivers.minlink.emulated import EmulatedRobot
from esair_std.errors import StdError
from tests.support.hmi import PAPAMAN, Robot, esair_std, open_page, wait_for
from tests.std.test_std_stop import DANCE_FRAMES, DANCES, after_stop, frames

BANNER = re.compile(r"STOPPED by hmi:operator at \d\d:\d\d:\d\d: every command is refused "
                    r"until an operator releases it")
REFUSED = re.compile(r"error: papaman\.motion: stopped by hmi:operator at \d\d:\d\d:\d\d: "
                     r"release with esair std release\n")


class TracedRobot(Robot):
    """Robot, its trace with the lines the robot received (``--trace-rx``)."""

    def __init__(self, mode, tmp):
        super().__init__(mode, tmp)
        self.emu = EmulatedRobot(PAPAMAN, ["--trace", str(self.trace), "--trace-rx"])


@pytest.fixture(scope="module", params=["thread", "process"])
def robot(request, tmp_path_factory):
    r = TracedRobot(request.param, tmp_path_factory.mktemp(f"hmi-stop-{request.param}"))
    try:
        yield r.start()
    finally:
        r.stop()
    assert r.proc.returncode == 0, (r.tmp / "run.err").read_text()


def latch_text(page) -> str:
    return page.evaluate("() => document.getElementById('latch').hidden ? '' : "
                         "document.getElementById('latch-text').textContent")


def test_stop_in_the_page_holds_until_an_operator_releases(robot, browser):
    """The runtime is asked over one control session (as `esair std put/get/ping/send`
    ask it, without a process each); the command line's refusal is the CLI's own."""
    page, errors = open_page(browser, robot.url)
    r = robot.call("put", {"to": "sequencer", "data": ["dance"] * DANCES, "timeout": 1.0,
                           "wait": True}, timeout=6.0)
    assert r["delivered"], r
    wait_for(lambda: len(frames(robot.trace_lines())) >= 3, what="a dance playing")
    page.click("#stop")
    page.wait_for_function("() => !document.getElementById('latch').hidden")
    assert BANNER.fullmatch(latch_text(page)), latch_text(page)
    assert page.locator("#release").is_visible()
    # a page opened later shows it (a viewer: no Release button, and its release refused)
    later, more = open_page(browser, robot.url, login=False)
    assert BANNER.fullmatch(latch_text(later))
    assert not later.locator("#release").is_visible()
    r = later.evaluate("window.__hmi.send({op: 'release'})")
    assert (r["ok"], r["error"]) == (False, "viewers cannot command: log in as an operator")
    # every sender refused with the STOP's words: the command line, the page, behaviors
    r = esair_std("send", "papaman.motion", "stand", "-e", robot.endpoint)
    assert r.returncode == 1 and REFUSED.fullmatch(r.stderr), r.stderr
    r = page.evaluate("window.__hmi.send({op: 'cmd', resource: 'papaman.servo.l_knee', "
                      "command: {angle: 100}})")
    assert not r["ok"] and "stopped by hmi:operator at " in r["error"], r
    seq = robot.call("get", {"to": "sequencer", "timeout": 1.0}, timeout=6.0)
    assert seq["ok"] and seq["data"]["queued"] == [] and seq["data"]["playing"] is None, seq
    stopped = robot.call("ping")["stopped"]
    assert stopped["by"] == "hmi:operator", stopped
    # the robot's trace while STOPPED: nothing moved after its x
    lines = robot.trace_lines()
    at, moved = after_stop(lines)
    assert moved == [], moved[:5]
    cut = len(frames(lines))
    assert cut < DANCE_FRAMES * DANCES, cut      # stopped before the last dance ended
    # the operator's Release: every page's banner goes; commands move the robot again;
    # nothing queued played meanwhile or after
    page.click("#release")
    for p in (page, later):
        p.wait_for_function("() => document.getElementById('latch').hidden")
    assert robot.call("ping")["stopped"] is None
    robot.send("papaman.servo.l_knee", 100)
    lines = robot.trace_lines()
    assert any(ln.startswith("W 10 ") and len(ln.split()[2]) == 6 for ln in lines[at:])
    assert len(frames(lines)) == cut
    later.close()
    page.close()
    assert errors == more == []


RACE = """async (op) => await window.__hmi.send({op})"""


def _send_on_a_live_link(robot) -> StdError | None:
    """The runtime's send of one servo angle (as `esair std send`'s), None once it went
    through, else what refused it. A link that a loaded machine kept past the robot's
    1 s reply timeout is lost for a moment and comes back by itself: the send is made
    again then (a refusal for STOP is never "lost")."""
    tries: list[StdError | None] = []

    def once() -> bool:
        try:
            robot.send("papaman.servo.l_knee", 100)
            tries.append(None)
        except StdError as exc:
            tries.append(exc)
        return ": lost: " not in str(tries[-1])

    wait_for(once, timeout=30, what=lambda: f"a send on a live link ({tries[-1]})")
    return tries[-1]


def test_stop_and_release_racing_from_two_pages_leave_everyone_agreeing(robot, browser):
    """Each round the runtime's state is read, and a command sent, over one control
    session (as `esair std ls` and `send` do, without a process each)."""
    a, errors = open_page(browser, robot.url)
    b, more = open_page(browser, robot.url)
    for _ in range(6):
        # both sent before either is answered (each page's own socket)
        a.evaluate("() => { window.__race = window.__hmi.send({op: 'stop'}); }")
        b.evaluate("() => { window.__race = window.__hmi.send({op: 'release'}); }")
        a.evaluate("() => window.__race")
        b.evaluate("() => window.__race")
        stopped = robot.call("ping").get("stopped")
        want = "" if stopped is None else "STOPPED"
        for p in (a, b):
            wait_for(lambda p=p, w=want: latch_text(p).startswith(w)
                     and bool(latch_text(p)) == bool(w),
                     what="the page's banner agreeing with the runtime")
        refused = _send_on_a_live_link(robot)
        assert (refused is None) == (stopped is None), (stopped, refused)
        if stopped is None:
            assert b.evaluate(RACE, "stop")["ok"]           # the next round starts STOPPED
    assert a.evaluate(RACE, "release")["ok"]
    a.close()
    b.close()
    assert errors == more == []


def test_an_hmi_started_while_stopped_shows_it_and_a_recording_keeps_it(tmp_path):
    """The STOP lives in the runtime: an HMI (a bridge) started while it holds shows
    it from its hello on (an HMI restarted, a page opened later), is told of each
    change, and a recording holds the state from its start (channel ``latch``)."""
    from esair_std import Runtime
    from esair_std.hmi.bridge import Bridge
    from esair_std.record import read_latch, read_samples
    from esair_std.record.recorder import Recorder
    from tests.support.std import free_endpoint

    dep = {"robot": "t", "resources": {"count": {"class": "tests.support.lean_comps:Counting",
                                                 "allow": {"*": "read"}}}}
    rt = Runtime(dep, mode="thread", endpoint=free_endpoint(), control=True,
                 stopped="maintenance")
    rt.start()
    got: list[dict] = []
    bridge = Bridge(rt.endpoint, got.append)
    rec = Recorder(rt.endpoint, str(tmp_path / "r.mcap"), ["nothing"])
    try:
        bridge.start()
        hello = bridge.hello()["latch"]
        assert (hello["stopped"], hello["by"], hello["reason"]) == (True, "operator",
                                                                   "maintenance")
        rec.start()
        rt.release_robot()
        wait_for(lambda: any(m["t"] == "latch" and m["v"]["stopped"] is False
                             and m["v"]["released_by"] == "operator" for m in got),
                 what="the release told")
        rt.stop_robot("again", by="hmi:ann")
        wait_for(lambda: bridge.latch.get("by") == "hmi:ann", what="the STOP told")
        # the recorder hears it on a bridge of its own: stopped only once it wrote it
        wait_for(lambda: rec.tap is not None and rec.tap._latches >= 3,
                 what="the recorder wrote the three states")
    finally:
        c = rec.stop()
        bridge.close()
        rt.stop()
    assert c["written"] == 0 and c["channels"] == 1        # no sensor asked for: the STOPs
    states = [(v["stopped"], v.get("by"), v.get("reason"))
              for _t, v in read_latch(tmp_path / "r.mcap")]
    assert list(read_samples(tmp_path / "r.mcap")) == []     # not samples of a sensor
    assert states == [(True, "operator", "maintenance"), (False, None, None),
                      (True, "hmi:ann", "again")]
