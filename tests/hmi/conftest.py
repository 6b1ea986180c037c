"""Fixtures of the HMI's browser tests: one headless chromium per session with one
browser context every page opens in, one ``esair std run papaman --hmi`` per mode
(tests/support/hmi.py)."""

from __future__ import annotations

import os

import pytest

from tests.support.hmi import CHROMIUM, CHROMIUM_ARGS, Robot


@pytest.fixture(scope="session")
def browser():
    """The session's browser context (a profile of one chromium): a page opened in it
    costs no new context and its renderer starts warm. Pages share its cookies and
    cache, not their sessionStorage, where a page keeps its login."""
    from playwright.sync_api import sync_playwright
    if not os.path.exists(CHROMIUM):
        pytest.fail(f"{CHROMIUM} is missing: run scripts/install-toolchain.sh (apt-get install "
                    "chromium)", pytrace=False)
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        context = b.new_context(viewport={"width": 1280, "height": 800})
        yield context
        context.close()
        b.close()


@pytest.fixture(scope="module", params=["thread", "process"])
def robot(request, tmp_path_factory):
    r = Robot(request.param, tmp_path_factory.mktemp(f"hmi-{request.param}"))
    try:
        yield r.start()
    finally:
        r.stop()
    assert r.proc.returncode == 0, (r.tmp / "run.err").read_text()
