"""The HMI server's log of what it sent (esair_std/hmi/server.py), with a bridge that
refuses or accepts everything (the running system's refusals: tests/hmi/test_hmi_truth.py):
one line per command, refused or not; a refused STOP is never logged as a STOP that
happened; the page's answer says the line is written (``logged``: the page adds none)."""

from __future__ import annotations

import asyncio
import json
import threading
import time
from typing import Any

import pytest

from esair_std.hmi.auth import Auth
from esair_std.hmi.bridge import BridgeError
from esair_std.hmi.server import HmiServer, Page

WHY = "papaman.motion: lost: link down: the device disconnected"


class Bridge:
    """The runtime's side as the server uses it: every request refused (``refuse``) or
    answered."""

    robots: dict[str, Any] = {"papaman": {}}
    rows: list[dict] = []
    latch = None

    def __init__(self, refuse: bool):
        self.refuse = refuse

    def command(self, res: str, command: Any, timeout: float = 2.0) -> Any:
        if self.refuse:
            raise BridgeError(f"{res}: lost: link down: the device disconnected")
        return {"line": "x", "at": time.time()}

    def call(self, verb: str, body: dict | None = None, timeout: float = 5.0) -> Any:
        if self.refuse:
            raise BridgeError(WHY)
        return {"by": "hmi:operator", "at": "12:00:00", "line": "x"}

    ask = call      # the server asks STOP and release with Bridge.ask (an object answer)


def run(refuse: bool, frame: dict) -> tuple[list[dict], list[str]]:
    """``frame`` from an operator's page: its answers and the log's lines (level text)."""
    srv = HmiServer("tcp/127.0.0.1:1", "127.0.0.1", 0, Auth("127.0.0.1"))
    srv.bridge = Bridge(refuse)
    answers: list[dict] = []
    lines: list[str] = []
    srv._send = lambda pages, text: answers.append(json.loads(text))
    srv.emit = lambda m: lines.append(f"{m['level']} {m['text']}") if m.get("t") == "log" else None
    page = Page(None, "operator")
    page.user = "ann"
    # a loop of its own, on a thread of its own: the browser tests' Playwright may run
    # one on this thread (its session-wide browser)
    errors: list[BaseException] = []

    def serve() -> None:
        try:
            asyncio.run(srv._frame(page, json.dumps(dict(frame, id=7))))
        except BaseException as exc:  # noqa: BLE001 - raised again below
            errors.append(exc)
    t = threading.Thread(target=serve)
    t.start()
    t.join(30)
    assert not t.is_alive() and errors == [], errors
    return answers, lines


def test_a_refused_stop_is_logged_once_as_refused_never_as_a_stop():
    answers, lines = run(True, {"op": "stop"})
    assert not any(ln.startswith("warning") for ln in lines), lines
    assert len(lines) == 1 and lines[0].startswith("error ") and "STOP" in lines[0], lines
    assert "link down" in lines[0]
    assert [(a["id"], a["ok"], a.get("logged")) for a in answers] == [(7, False, True)]
    assert "link down" in answers[0]["error"]


def test_a_stop_that_went_through_is_logged_once():
    answers, lines = run(False, {"op": "stop"})
    assert [(a["id"], a["ok"]) for a in answers] == [(7, True)]
    assert len(lines) == 1 and lines[0].startswith("warning STOP by "), lines


@pytest.mark.parametrize("refuse", [True, False])
def test_one_line_per_command_refused_or_not(refuse):
    answers, lines = run(refuse, {"op": "cmd", "resource": "papaman.servo.r_knee",
                                  "command": {"angle": 40}})
    assert [(a["id"], a["ok"], a.get("logged")) for a in answers] == [
        (7, not refuse, True if refuse else None)]
    assert len(lines) == 1, lines
    assert 'ann: papaman.servo.r_knee {"angle":40}' in lines[0], lines
    if refuse:                                      # the resource named once
        assert lines[0] == ('error ann: papaman.servo.r_knee {"angle":40} refused: '
                            'lost: link down: the device disconnected'), lines
