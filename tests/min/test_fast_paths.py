"""The emulator's fast paths give what the plain paths give (issue 22 item 6): a run of
bytes into the line assembler, the flow sensor's burst read, and the drive board's
skipped ticks, each against the plain path over hypothesis-generated input."""

from __future__ import annotations

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from esair_min.components.dc_motor.core import DriveCore
from esair_min.components.optical_flow.core import Adns2610, FlowTimingError, read_deltas
from esair_min.core.decoder import LineAssembler

PROPS = settings(max_examples=200, deadline=None,
                 suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
# bytes a line is made of, line ends, and the odd bad byte, in runs past the 40-byte line
STREAM = st.lists(st.one_of(st.sampled_from(b"V+0200-0100x*AF\r\n\r\n"), st.integers(0, 255),
                            st.just(0x41)), max_size=120)


def _state(a: LineAssembler) -> tuple:
    return (bytes(a.buf[:a.length]), a.length, a.overflow, a.bad, a.overrun, a.after_cr)


@PROPS
@given(chunks=st.lists(STREAM.map(bytes), max_size=6), gaps=st.lists(st.booleans(), max_size=6))
def test_a_run_into_the_line_assembler_is_each_byte_in_turn(chunks, gaps):
    one, run = LineAssembler(), LineAssembler()
    for k, data in enumerate(chunks):
        if k < len(gaps) and gaps[k]:             # bytes lost before this chunk
            one.note_overrun()
            run.note_overrun()
        plain = [r for r in (one.feed(b) for b in data) if r is not None]
        assert run.feed_run(data) == plain
        assert _state(run) == _state(one)


@PROPS
@given(moves=st.lists(st.tuples(st.floats(-40, 40), st.floats(-40, 40), st.booleans()),
                      max_size=12),
       noise=st.sampled_from([0.0, 0.02]))
def test_the_flow_sensors_burst_read_is_its_three_register_reads(moves, noise):
    plain, burst = Adns2610(noise=noise, seed=3), Adns2610(noise=noise, seed=3)
    t = 0
    for dx, dy, lifted in moves:
        for s in (plain, burst):
            s.lifted = lifted
            s.move(dx, dy, 0.01)
        got, want = burst.deltas(t), read_deltas(plain, t)
        assert got == want
        assert (burst._acc, burst._free_at, burst._reg, burst._addr_at, burst.lost) == \
            (plain._acc, plain._free_at, plain._reg, plain._addr_at, plain.lost)
        t = got[3] + 1_000_000


def test_the_burst_read_refuses_a_read_before_the_sensor_is_ready():
    s = Adns2610()
    s.write(0, 1, 1_000)
    try:
        s.deltas(50_000)
    except FlowTimingError as exc:
        assert str(exc) == "address 0x02 at 50000 ns, before the sensor is ready at 101000 ns"
    else:
        raise AssertionError("no FlowTimingError")


@PROPS
@given(steps=st.lists(st.tuples(st.integers(0, 5), st.binary(max_size=8), st.integers(0, 30)),
                      max_size=10))
def test_the_drive_boards_skipped_ticks_change_nothing(starfish, steps):
    board = starfish.board("drive")
    skipping, full = DriveCore(board), DriveCore(board)
    for first, data, ticks in steps:
        skipping.write(first, data)
        full.write(first, data)
        for _ in range(ticks):
            skipping.tick()
            full._settled = False                  # the plain path: every tick computed
            full.tick()
            assert skipping.motors == full.motors
            assert skipping.rims == full.rims == tuple(m.rim_speed for m in full.motors)


def test_the_sims_replayed_drive_ticks_are_the_ticks_run_as_events(starfish):
    """While the drive board is settled its ticks are not events: the sim replays where
    each would have ended a stretch of wheel travel. Against a sim whose drive board is
    never taken for settled (every tick an event): the same trace, bus and poses."""
    from esair_min.components.omni_base.core import velocity_line
    from esair_min.emulator.starfish import FlowOptions, StarfishSim, drive_square
    from esair_min.world import Pose, World

    def run(eager: bool) -> tuple:
        sim = StarfishSim(starfish, World(pose=Pose(3800, 700, 0.2)), FlowOptions(noise=0.02))
        if eager:
            type(sim.drive).settled = property(lambda self: False)  # type: ignore[assignment]
        square = drive_square(sim, 1000, laps=1)
        replies = []
        for k in range(60):                       # toward the wall at x = 5000, turning
            replies.append(sim.command(velocity_line(400, 0, 100 - 4 * k)))
            sim.run_for(0.05)
        sim.run_for(1.2)                          # the watchdog stops it, it ramps down
        replies.append(sim.read())
        return square, replies, sim.trace, sim.i2c, sim.world.pose, sim.world.collisions

    import esair_min.components.dc_motor.core as dc
    settled = dc.DriveCore.settled
    lazy = run(False)
    try:
        eager = run(True)
    finally:
        dc.DriveCore.settled = settled            # type: ignore[method-assign]
    assert eager == lazy
    assert lazy[5] >= 1 and b"!W watchdog stop" in lazy[1][-1]
