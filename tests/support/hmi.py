"""Helpers of the browser tests of the HMI (docs/hmi.md): Playwright driving Debian's
chromium headless (``playwright install`` downloads a browser, which cannot work here: the project's
install step installs ``chromium`` with apt), against ``esair std run papaman --hmi``
with its own emulated robot (traced), in both modes."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
from pathlib import Path

from bench.toolkit import CHROMIUM, CHROMIUM_ARGS, free_port  # noqa: F401  (the tests' too)
from esair_std.cli.client import Client
from esair_std.drivers.minlink.emulated import EmulatedRobot
from tests.support.std import wait_for as std_wait_for

ROOT = Path(__file__).resolve().parents[2]
PAPAMAN = ROOT / "boards" / "papaman"
PASSWORD = "correct horse"


def wait_for(fn, timeout=20.0, what="condition"):
    """tests.support.std.wait_for, with the browser tests' longer default timeout."""
    return std_wait_for(fn, timeout, what)


def esair_std(*args: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-m", "esair_min.cli", "std", *args],
                          capture_output=True, text=True, timeout=60, env=env)


class HmiRun:
    """``esair std run ROBOT --hmi`` (``args``: the robot and its options) in ``mode``,
    the HMI on a free port of 127.0.0.1, its stderr in ``tmp/run.err``; ``start()``
    returns once the HMI's URL is printed."""

    def __init__(self, mode: str, tmp: Path, args: list[str]):
        self.mode, self.tmp, self.args = mode, tmp, args
        self.endpoint = f"tcp/127.0.0.1:{free_port()}"
        self.url = ""
        self.proc: subprocess.Popen | None = None
        self.client: Client | None = None

    def env(self) -> dict[str, str]:
        return dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))

    def start(self):
        self.errors = open(self.tmp / "run.err", "w+")      # noqa: SIM115 - closed in stop()
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "esair_min.cli", "std", "run", *self.args, "--hmi",
             "--hmi-listen", "127.0.0.1:0", "--mode", self.mode, "-e", self.endpoint, "--no-top"],
            stdout=subprocess.DEVNULL, stderr=self.errors, env=self.env(), cwd=self.tmp)

        def url():
            if self.proc.poll() is not None:
                raise AssertionError(f"esair std run exited: {(self.tmp / 'run.err').read_text()}")
            m = re.search(r"^hmi: (http://\S+)$", (self.tmp / "run.err").read_text(), re.M)
            return m and m.group(1)
        self.url = wait_for(url, timeout=120, what="the HMI's URL")
        return self

    def std(self, *args: str) -> str:
        """``esair std ARGS -e ENDPOINT``'s standard output (it must succeed)."""
        r = esair_std(*args, "-e", self.endpoint)
        assert r.returncode == 0, r.stderr
        return r.stdout

    def call(self, verb: str, body: dict | None = None, timeout: float | None = None):
        """The runtime's answer to a control request, over one session kept open (the
        one `esair std VERB` opens each time: no process per question)."""
        if self.client is None:
            self.client = Client(self.endpoint)
        return self.client.call(verb, body, timeout)

    def send(self, name: str, value) -> object:
        """An actuator's answer to ``value``, as `esair std send NAME VALUE` sends it."""
        return self.call("send", {"name": name, "value": value, "timeout": 1.0}, timeout=6.0)

    def stop(self) -> None:
        if self.client is not None:
            self.client.close()
            self.client = None
        if self.proc is not None:
            self.proc.send_signal(signal.SIGTERM)
            self.proc.wait(timeout=30)
            self.errors.close()


class Robot(HmiRun):
    """``esair std run papaman --hmi`` against a traced emulated PAPA-MAN (an operator
    logs in with PASSWORD), its push scenario held: its feet at rest until
    ``emu.play_scenario()`` plays the push (boards/papaman/scenarios/push.yaml)."""

    def __init__(self, mode: str, tmp: Path):
        self.trace = tmp / "trace.txt"
        self.emu = EmulatedRobot(PAPAMAN, ["--trace", str(self.trace), "--scenario", "push",
                                           "--hold-scenario"])
        super().__init__(mode, tmp, ["papaman"])

    def env(self) -> dict[str, str]:
        return dict(super().env(), ESAIR_HMI_PASSWORD=PASSWORD)

    def start(self) -> "Robot":
        self.args = ["papaman", "--port", self.emu.start()]
        return super().start()

    def status(self) -> dict:
        import urllib.request
        with urllib.request.urlopen(self.url + "status.json", timeout=5) as r:
            return json.load(r)

    def trace_lines(self) -> list[str]:
        return self.trace.read_text().splitlines() if self.trace.exists() else []

    def stop(self) -> None:
        super().stop()
        self.emu.stop()


def open_page(browser, url: str, login: bool = True, width: int = 1280, height: int = 800,
              ready: str = "window.__hmi.info"):
    """A page on the HMI (logged in as the operator unless ``login`` is False) once its
    WebSocket is up and ``ready`` (a JavaScript expression) holds, and the console errors
    and page errors it collects. ``browser``: the tests' browser context (or a browser)."""
    page = browser.new_page()
    if page.viewport_size != {"width": width, "height": height}:
        page.set_viewport_size({"width": width, "height": height})
    errors: list[str] = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    reopen(page, url, ready)
    if login:
        log_in(page)
    return page, errors


def log_in(page) -> None:
    """The operator logs in: the login form submitted as its button does (one step, not
    Playwright's typing and click; test_the_page_loads_without_errors_and_lists_every_component
    clicks)."""
    page.evaluate("""pw => { document.getElementById("login-pass").value = pw;
                             document.getElementById("login").requestSubmit(); }""", PASSWORD)
    page.wait_for_function("() => window.__hmi.role === 'operator'")


def reopen(page, url: str, ready: str = "window.__hmi.info") -> None:
    """``page`` loads ``url`` anew (a new document, a new WebSocket: a page opened then,
    without a new tab's cost; its errors go on into open_page's list; a tab that logged
    in logs in again with its token) and returns once its WebSocket is up and ``ready``
    holds."""
    page.goto(url, wait_until="commit")
    # ``ready`` may read what the runtime's hello makes (window.__hmi.feet...), which comes
    # after the WebSocket is up: until then it is false (or not yet defined), not an error
    page.wait_for_function(f"() => {{ try {{ return !!(window.__hmi && window.__hmi.wsUp "
                           f"&& ({ready})); }} catch (e) {{ return false; }} }}")
