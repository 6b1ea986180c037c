"""A short timeout is honoured (issue 37 item 3): a put or get with a timeout well under
a second, to a behavior busy by its own word, gives up before the behavior frees. Shown
by the order of events: the behavior is freed by a thread of the test some seconds after
the call began, and the call must have given up first (a deadline stretched, ignored, or
counted from the wrong moment lets the call wait for the freed target and succeed)."""

from __future__ import annotations

import threading

import pytest

from esair_std.errors import ControlError
from tests.support.std import wait_for

LATER_S = 3.0          # the gate frees itself this long after the call began (15x 0.2 s)


@pytest.mark.parametrize("verb", ["put", "get"])
def test_a_short_timeout_gives_up_before_the_busy_target_frees(start, tmp_path, verb):
    release = tmp_path / "release"
    rt = start({"behaviors": {"gate": {"class": "tests.support.comps:Gate",
                                       "release": str(release)}}})
    rt.put("gate", "close")
    wait_for(lambda: rt.state("gate") == "busy", 10, what="the gate to close")
    events: list[str] = []
    lock = threading.Lock()

    def free_later(began: threading.Event) -> None:
        began.wait()
        if not gave_up.wait(LATER_S):
            with lock:
                events.append("freed")
            release.touch()

    began, gave_up = threading.Event(), threading.Event()
    freer = threading.Thread(target=free_later, args=(began,))
    freer.start()
    began.set()
    try:
        with pytest.raises(ControlError) as e:
            if verb == "put":
                rt.put("gate", "in vain", timeout=0.2)
            else:
                rt.get("gate", timeout=0.2)
        with lock:
            events.append("gave up")
        gave_up.set()
    finally:
        gave_up.set()
        freer.join()
    assert events == ["gave up"], f"the call waited for the target: {events}, {e.value}"
    assert "within 0.2 s" in str(e.value)
    release.touch()
    rt.put("gate", "later", timeout=10.0)
    assert wait_for(lambda: rt.get("gate"), 10, what="the gate")["got"] == ["close", "later"]
