"""Screenshots of the HMI for docs/hmi.md: `esair std run papaman --hmi` against an
emulated PAPA-MAN pushed by its `push` scenario, in headless chromium (Debian's, as the
browser tests use it), at 1280x800 and 390 px wide.

    python scripts/hmi_screenshots.py [OUT_DIR]      # default docs/img
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import yaml
from playwright.sync_api import sync_playwright

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.support.hmi import CHROMIUM, CHROMIUM_ARGS, PAPAMAN, Robot, open_page  # noqa: E402


def main(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix="hmi-shots-"))
    push = yaml.safe_load((PAPAMAN / "scenarios" / "push.yaml").read_text())
    for step in push["steps"][1:]:
        step["at_ms"] += 3000
    (tmp / "push.yaml").write_text(yaml.safe_dump(push))
    robot = Robot("thread", tmp).start()
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
            page, errors = open_page(browser, robot.url)
            robot.restart_robot("--scenario", str(tmp / "push.yaml"))
            page.wait_for_function("() => window.__hmi.feet.markers.length > 0", timeout=30000)
            time.sleep(1.5)
            page.click("#motions button[data-motion=dance]")
            time.sleep(0.15)                          # the stick figure mid-dance
            page.screenshot(path=str(out / "hmi-1280.png"))
            robot.emu.kill()
            page.wait_for_selector("#banner", state="visible")
            page.screenshot(path=str(out / "hmi-link-lost.png"),
                            clip={"x": 0, "y": 0, "width": 1280, "height": 300})
            robot.emu.start()
            page.wait_for_selector("#banner", state="hidden", timeout=20000)
            narrow, errors2 = open_page(browser, robot.url, width=390, height=844)
            time.sleep(1.0)
            narrow.screenshot(path=str(out / "hmi-390.png"), full_page=True)
            if errors or errors2:
                raise SystemExit(f"console errors: {errors + errors2}")
            browser.close()
    finally:
        robot.stop()
    for name in ("hmi-1280.png", "hmi-link-lost.png", "hmi-390.png"):
        print(out / name)


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs" / "img")
