"""The one restart-intensity rule (esair_std/restart_window.py) that the supervisor, a
remote agent and a MIN link's emulated robot share: at most ``max`` restarts in any
``within`` seconds, a restart exactly ``within`` seconds ago still counting (OTP)."""

from esair_std.restart_window import RestartWindow


def test_the_boundary_a_restart_exactly_within_seconds_ago_still_counts():
    w = RestartWindow(2, 10.0)
    assert w.allow(100.0) and w.allow(105.0)
    assert not w.allow(110.0)               # 100.0 is exactly 10 s ago: 2 in the window
    assert len(w) == 2
    assert w.allow(110.001)                 # 100.0 has left the window; 105.0 and now count
    assert len(w) == 2 and not w.allow(115.0)
    assert w.allow(115.002)


def test_a_refused_restart_is_not_counted():
    w = RestartWindow(1, 5.0)
    assert w.allow(0.0)
    assert [w.allow(t) for t in (1.0, 2.0, 5.0)] == [False, False, False]
    assert w.allow(5.5) and len(w) == 1     # only the allowed restarts fill the window


def test_max_zero_never_restarts():
    w = RestartWindow(0, 60.0)
    assert not w.allow(0.0) and not w.allow(1e6) and len(w) == 0
