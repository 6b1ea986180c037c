"""``esair std run starfish --hmi`` for the browser tests (tests/hmi/test_hmi_starfish.py)
and scripts/hmi_starfish_screenshot.py: the bundled example with its own emulated boards,
the HMI on a free port of 127.0.0.1 (every page an operator)."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
from pathlib import Path

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


def open_page(browser, url: str):
    page = browser.new_page(viewport={"width": 1280, "height": 900})
    errors: list[str] = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto(url)
    page.wait_for_function("() => window.__hmi && window.__hmi.wsUp && window.__hmi.generic")
    return page, errors
