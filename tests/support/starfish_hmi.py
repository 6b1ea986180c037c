"""``esair std run starfish --hmi`` for the browser tests (tests/hmi/test_hmi_starfish.py)
and scripts/hmi_starfish_screenshot.py: the bundled example with its own emulated boards,
the HMI on a free port of 127.0.0.1 (every page an operator)."""

from __future__ import annotations

from pathlib import Path

from tests.support.hmi import ROOT, HmiRun
from tests.support.hmi import open_page as hmi_page

ROOM = ROOT / "esair_std" / "examples" / "starfish" / "room.yaml"
MAP = "window.__hmi.generic.maps.starfish"


class StarfishHmi(HmiRun):
    """``esair std run starfish --hmi`` (the bundled example, its own emulated boards)."""

    def __init__(self, mode: str, tmp: Path):
        super().__init__(mode, tmp, ["starfish"])

    def env(self) -> dict[str, str]:
        env = super().env()
        env.pop("ESAIR_HMI_PASSWORD", None)            # on 127.0.0.1: every page an operator
        return env

    def get(self, name: str) -> dict:
        """Behavior ``name``'s data (its provide()), as `esair std get` asks it."""
        r = self.call("get", {"to": name, "timeout": 1.0}, timeout=6.0)
        assert r["ok"], r
        return r["data"]

    def configure(self, resource: str, key: str, value: object) -> None:
        """``key`` of ``resource`` set to ``value``, as `esair std configure` sets it."""
        self.call("configure", {"resource": resource, "key": key, "value": value})


def open_page(browser, url: str):
    """A page on STARFISH's HMI (an operator: no login) once its generic panels are made."""
    return hmi_page(browser, url, login=False, height=900, ready="window.__hmi.generic")
