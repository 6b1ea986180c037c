"""Helpers of the browser tests of the HMI (docs/hmi.md): Playwright driving Debian's
chromium headless (``playwright install`` downloads a browser, which cannot work here: the project's
install step installs ``chromium`` with apt), against ``esair std run papaman --hmi``
with its own emulated robot (traced), in both modes."""

from __future__ import annotations

import json
import os
import re
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

from esair_std.drivers.minlink.emulated import EmulatedRobot

ROOT = Path(__file__).resolve().parents[2]
PAPAMAN = ROOT / "boards" / "papaman"
CHROMIUM = "/usr/bin/chromium"
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--no-first-run"]
PASSWORD = "correct horse"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_for(fn, timeout=20.0, what="condition"):
    """Poll fn() until it returns a truthy value (state-based; no timing asserted)."""
    deadline = time.monotonic() + timeout
    while True:
        v = fn()
        if v:
            return v
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}; last value {v!r}")
        time.sleep(0.02)


def esair_std(*args: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-m", "esair_min.cli", "std", *args],
                          capture_output=True, text=True, timeout=60, env=env)


class Robot:
    """``esair std run papaman --hmi`` against a traced emulated PAPA-MAN."""

    def __init__(self, mode: str, tmp: Path):
        self.mode, self.tmp = mode, tmp
        self.trace = tmp / "trace.txt"
        self.emu = EmulatedRobot(PAPAMAN, ["--trace", str(self.trace)])
        self.endpoint = f"tcp/127.0.0.1:{free_port()}"
        self.url = ""
        self.proc: subprocess.Popen | None = None

    def start(self) -> "Robot":
        self.emu.start()
        env = dict(os.environ, ESAIR_HMI_PASSWORD=PASSWORD,
                   PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
        self.errors = open(self.tmp / "run.err", "w+")      # noqa: SIM115 - closed in stop()
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "esair_min.cli", "std", "run", "papaman", "--hmi",
             "--hmi-listen", "127.0.0.1:0", "--port", self.emu.port, "--mode", self.mode,
             "-e", self.endpoint, "--no-top"],
            stdout=subprocess.DEVNULL, stderr=self.errors, env=env, cwd=self.tmp)

        def url():
            if self.proc.poll() is not None:
                raise AssertionError(f"esair std run exited: {(self.tmp / 'run.err').read_text()}")
            m = re.search(r"^hmi: (http://\S+)$", (self.tmp / "run.err").read_text(), re.M)
            return m and m.group(1)
        self.url = wait_for(url, timeout=90, what="the HMI's URL")
        return self

    def restart_robot(self, *extra: str) -> None:
        self.emu.kill()
        self.emu.start(extra)

    def status(self) -> dict:
        import urllib.request
        with urllib.request.urlopen(self.url + "status.json", timeout=5) as r:
            return json.load(r)

    def trace_lines(self) -> list[str]:
        return self.trace.read_text().splitlines() if self.trace.exists() else []

    def stop(self) -> None:
        if self.proc is not None:
            self.proc.send_signal(signal.SIGTERM)
            self.proc.wait(timeout=30)
            self.errors.close()
        self.emu.stop()


def open_page(browser, url: str, login: bool = True, width: int = 1280, height: int = 800):
    """A page on the HMI (logged in as the operator unless ``login`` is False), and the
    console errors and page errors it collects."""
    page = browser.new_page(viewport={"width": width, "height": height})
    errors: list[str] = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto(url)
    page.wait_for_function("() => window.__hmi && window.__hmi.info && window.__hmi.wsUp")
    if login:
        page.fill("#login-pass", PASSWORD)
        page.click("#login button")
        page.wait_for_function("() => window.__hmi.role === 'operator'")
    return page, errors
