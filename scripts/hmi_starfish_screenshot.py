"""The screenshot of STARFISH on the HMI for docs/hmi.md and docs/std-starfish.md:
`esair std run starfish --hmi` (its emulated boards), the sound source switched on, the
page taken once turn_and_shoot's picture shows and localize's bearing is on the map.

    python scripts/hmi_starfish_screenshot.py [OUT_DIR]      # default docs/img
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

from playwright.sync_api import sync_playwright

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.support.hmi import CHROMIUM, CHROMIUM_ARGS  # noqa: E402
from tests.support.starfish_hmi import MAP, StarfishHmi, open_page  # noqa: E402


def main(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    hmi = StarfishHmi("thread", Path(tempfile.mkdtemp(prefix="hmi-starfish-"))).start()
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
            page, errors = open_page(browser, hmi.url)
            hmi.std("configure", "starfish.mics", "source", '{"x": 1.0, "y": 3.5, "on": true}')
            page.wait_for_function("() => window.__hmi.generic.panels['starfish.pictures']",
                                   timeout=60000)
            page.wait_for_function(f"() => {MAP}.view.ray !== null", timeout=30000)
            time.sleep(1.0)
            page.screenshot(path=str(out / "hmi-starfish.png"), full_page=True)
            browser.close()
            if errors:
                raise SystemExit(f"console errors: {errors}")
    finally:
        hmi.stop()
    print(out / "hmi-starfish.png")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs" / "img")
