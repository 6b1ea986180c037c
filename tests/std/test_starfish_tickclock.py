"""The central board's tick on the host's clock from its odometry replies
(esair_std/drivers/starfish/tickclock.py): polls at every phase of the tick bound it
to a fraction of a millisecond; a restarted robot (its count back) starts afresh; the
16-bit count's wrap does not."""

from __future__ import annotations

import math

from esair_std.drivers.starfish.tickclock import TickClock

TICK, BYTE = 0.01, 10 / 38400


def _polls(clock: TickClock, origin: float, start: float, count: int, n_base: int = 0,
           k0: int = 0) -> list[float]:
    """``count`` O exchanges every 50 ms, dithered over a tick (as omnilink.Odometry's),
    against a board whose tick k is at ``origin + k * TICK``: a one-way delay of 0.3 ms,
    50 bytes of reply; the times of tick n the clock says."""
    out = []
    for k in range(k0, k0 + count):
        sent = start + 0.05 * (k - k0) + (k * 0.6180339887 % 1.0) * TICK
        decoded = sent + 0.0003 + 2 * BYTE
        n = (math.floor((decoded - origin) / TICK) + n_base) & 0xFFFF
        replied = decoded + 50 * BYTE + 0.0002
        out.append(clock.add(n, sent, 3, replied, 50) - (origin + (math.floor(
            (decoded - origin) / TICK)) * TICK))
    return out


def test_polls_at_every_phase_bound_the_tick_to_a_fraction_of_a_millisecond():
    clock = TickClock(TICK, BYTE)
    errors = _polls(clock, 12.3456, 100.0, 40)
    assert clock.spread() < 0.001
    assert all(abs(e) < 0.001 for e in errors[-10:]), errors[-10:]
    assert abs(errors[0]) <= TICK            # one poll alone: within a tick


def test_a_restarted_robot_starts_afresh_and_a_wrapped_count_does_not():
    clock = TickClock(TICK, BYTE)
    # the count wraps past 65535 after 20 polls
    _polls(clock, 12.3456, 100.0, 40, n_base=0x10000 - math.floor((100.0 - 12.3456) / TICK) - 100)
    assert clock.resets == 0 and clock.wraps == 1 and clock.spread() < 0.001
    errors = _polls(clock, 109.9041, 110.0, 40, k0=40)          # a new boot: n from 9
    assert clock.resets == 1
    assert all(abs(e) < 0.001 for e in errors[-10:]), errors[-10:]


def test_the_poll_at_rest_reads_the_first_tick_after_the_rest():
    """Odometry.poll_at(t) (the wheels at rest at t): once the polls tell the tick's
    phase, the extra poll's O is decoded within the first central tick from t (its sums
    see the rest, and come no later); before, a whole tick after t."""
    from esair_min.model.validate import load_robot
    from esair_min.resources import resolve_robot
    from esair_std.drivers.starfish.omniboard import omni_of
    from esair_std.drivers.starfish.omnilink import Odometry
    odo = Odometry(None, omni_of(load_robot(resolve_robot("starfish"))), 20.0,  # type: ignore[arg-type]
                   (0.0, 0.0, 0.0))
    origin = 12.3456
    odo.clock = TickClock(TICK, BYTE)               # this test's board: a 10 ms tick
    odo.poll_at(105.0)
    assert odo._poll_at is not None and odo._poll_at >= 105.0 + TICK
    _polls(odo.clock, origin, 100.0, 40)
    for t in (105.0, 105.0037, 105.0099):
        odo.poll_at(t)
        decoded = odo._poll_at + BYTE              # its 2 bytes' CR
        first = origin + math.ceil((t - origin) / TICK) * TICK
        assert first <= decoded < first + TICK, (t, decoded - first)
        assert decoded - first < 0.004
