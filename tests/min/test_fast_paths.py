"""The emulator's fast paths give what the plain paths give (issue 22 item 6): a run of
bytes (and a whole line) into the line assembler, the flow sensor's burst read and its
inline gaussian pair, the drive board's skipped ticks (and a write of the same speeds),
the world's advance without a Step, the V/W fields' regex and a repeated line's plan,
the sim's fused central tick and its ticks in runs, the direct line and reply of an
exchange, and the host's least squares, each against the plain path over
hypothesis-generated input or seeded runs."""

from __future__ import annotations

from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import math

from esair_min.components.dc_motor.core import DriveCore
from esair_min.components.omni_base.core import _FIELDS, signed_field
from esair_min.components.optical_flow.core import (MAX_SPEED_IPS, MM_PER_INCH, Adns2610,
                                                    FlowTimingError, read_deltas)
from esair_min.core.decoder import LineAssembler
from esair_min.world import Pose, Room, Segment, World, WorldOptions

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
@given(before=st.lists(STREAM.map(bytes), max_size=3),
       lines=st.lists(st.one_of(
           st.text(st.characters(min_codepoint=0x20, max_codepoint=0x7E), max_size=44)
           .map(str.encode),
           st.binary(max_size=44).map(lambda b: bytes(c & 0x7F for c in b))), min_size=1, max_size=6),
       ends=st.sampled_from([b"\r\n", b"\r", b"\n", b"\n\r"]))
@example(before=[], lines=[b"A" * 40, b"B" * 41, b"", b"C"], ends=b"\r\n")
def test_a_whole_line_into_the_line_assembler_is_each_byte_in_turn(before, lines, ends):
    """feed_run's whole-line path (a line of 1..40 printable bytes and CR LF from a
    clean start) against feed of each byte, after any stream and for lines that do not
    qualify (too long, empty, a control byte, other line ends): the same results and
    state."""
    one, run = LineAssembler(), LineAssembler()
    for data in before + [line + ends for line in lines]:
        plain = [r for r in (one.feed(b) for b in data) if r is not None]
        got = run.feed_run(data)
        assert got == plain and all(type(r) is type(p) for r, p in zip(got, plain, strict=True))
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
    from esair_min.emulator.starfish.robot_sim import FlowOptions, StarfishSim, drive_square
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


def _plain_move(s: Adns2610, dx_mm: float, dy_mm: float, dt_s: float) -> None:
    """The sensor's motion with random.gauss called for each axis (the plain path)."""
    dist = math.hypot(dx_mm, dy_mm)
    if s.lifted or (dt_s > 0 and dist / MM_PER_INCH / dt_s > MAX_SPEED_IPS):
        if dist:
            s.lost += 1
        return
    k = s.cpi / MM_PER_INCH
    gauss = s._rng.gauss
    s._acc[0] += (dx_mm + gauss(0.0, s.noise * abs(dx_mm))) * k
    s._acc[1] += (dy_mm + gauss(0.0, s.noise * abs(dy_mm))) * k


@PROPS
@given(moves=st.lists(st.tuples(st.floats(-40, 40), st.floats(-40, 40), st.booleans(),
                                st.booleans()), max_size=20),
       noise=st.sampled_from([0.01, 0.02, 0.5]), seed=st.integers(0, 9))
def test_the_flow_sensors_inline_gaussian_pair_is_random_gauss(moves, noise, seed):
    """Both draws of a move from one pair, inline; a pair already half drawn (another
    gauss before) goes through random.gauss: the same counts and generator state."""
    fast, plain = Adns2610(noise=noise, seed=seed), Adns2610(noise=noise, seed=seed)
    for dx, dy, lifted, draw_one in moves:
        if draw_one:                                 # leaves the pair's second pending
            assert fast._rng.gauss() == plain._rng.gauss()
        fast.lifted = plain.lifted = lifted
        fast.move(dx, dy, 0.01)
        _plain_move(plain, dx, dy, 0.01)
        assert fast._acc == plain._acc and fast.lost == plain.lost
        assert fast._rng.getstate() == plain._rng.getstate()


@PROPS
@given(steps=st.lists(st.tuples(st.floats(-900, 900), st.floats(-900, 900), st.floats(-4, 4),
                                st.sampled_from([0.0, 0.001, 0.01, 0.0099])), max_size=40),
       options=st.sampled_from([WorldOptions(), WorldOptions(radius_mm=400.0),
                                WorldOptions(lag_s=0.05),
                                WorldOptions(slip=0.1, slip_noise=0.05, seed=3)]),
       x=st.floats(160, 4840), theta=st.floats(-4, 4))
def test_the_worlds_advance_is_its_step(steps, options, x, theta):
    """World.advance (no Step, its own clear-of-walls path) against World.step, walls
    met and left, at rest, with lag and slip: the same motion and the same world."""
    room = Room((Segment(0, 0, 5000, 0), Segment(5000, 0, 5000, 1200),
                 Segment(5000, 1200, 0, 1200), Segment(0, 1200, 0, 0)))
    fast = World(room=room, pose=Pose(x, 600.0, theta), options=options)
    plain = World(room=room, pose=Pose(x, 600.0, theta), options=options)
    for vx, vy, omega, dt in steps:
        if dt == 0.0:
            continue
        st_ = plain.step(dt, vx, vy, omega)
        assert fast.advance(dt, vx, vy, omega) == (st_.vx, st_.vy, st_.omega, st_.collided)
        assert (fast.pose, fast.velocity, fast.t_s, fast.collisions, fast._touching,
                fast._checked, fast._margin, fast._rng.getstate()) == \
            (plain.pose, plain.velocity, plain.t_s, plain.collisions, plain._touching,
             plain._checked, plain._margin, plain._rng.getstate())
        assert type(fast.pose) is Pose and repr(fast.pose) == repr(plain.pose)


def test_the_worlds_advance_refuses_no_time_as_step_does():
    try:
        World().advance(0.0, 1.0, 0.0, 0.0)
    except ValueError as exc:
        assert str(exc) == "a step needs a time above 0 s, not 0.0"
    else:
        raise AssertionError("no ValueError")


@PROPS
@given(body=st.lists(st.sampled_from(b"+-0123456789 a*"), min_size=15, max_size=15).map(bytes),
       sign=st.sampled_from([b"+", b"-"]))
def test_the_fields_regex_is_signed_field_of_each(body, sign):
    for data in (body, sign + body[1:]):
        m = _FIELDS(b"V" + data, 1)
        plain = [signed_field(data[k:k + 5]) for k in (0, 5, 10)]
        if any(v is None for v in plain):
            assert m is None
        else:
            assert m is not None and [int(g) for g in m.groups()] == plain


def test_a_write_of_the_same_speeds_leaves_a_settled_drive_board_settled(starfish):
    board = starfish.board("drive")
    lazy, full = DriveCore(board), DriveCore(board)
    data = bytes([0x2C, 0x01, 0xD4, 0xFE, 0x00, 0x00])   # +300, -300, 0 mm/s
    for b in (lazy, full):
        b.write(0, data)
    for _ in range(100):
        lazy.tick()
        full.tick()
    assert lazy.settled and full.settled
    for k in range(40):
        lazy.write(0, data if k % 2 else data[:4])       # the same registers, all or some
        assert lazy.settled
        full.write(0, data if k % 2 else data[:4])       # the plain path: every tick run
        full._settled = False
        lazy.tick()
        full.tick()
        assert lazy.motors == full.motors and lazy.rims == full.rims
    lazy.write(2, bytes([0xD5]))                         # a change: it ticks again
    assert not lazy.settled


def _sim_run(robot, mode: str, world: World, noise: float, seed: int,
             clock_events: list | None = None) -> tuple:
    """A seeded run of the sim (a square, then toward a wall turning, the watchdog stop,
    a lifted sensor). ``mode``: "runs" as it is (ticks in runs: fused_run);
    "settled": every central tick an event of its own (_central_settled); "plain":
    that, through _timers_plain, and the travel through _replay and _advance, as before
    the fused paths."""
    from esair_min.components.omni_base.core import velocity_line, wheels_line
    from esair_min.emulator.starfish.robot_sim import FlowOptions, StarfishSim, drive_square

    sim = StarfishSim(robot, world, FlowOptions(noise=noise, seed=seed))
    if mode != "runs":
        sim._run_plan = None                              # central_run: one tick, plain
    if mode == "plain":
        sim._central_settled = sim._timers_plain          # type: ignore[method-assign]
        sim._account = sim._account_plain                 # type: ignore[method-assign]
    square = drive_square(sim, 800, laps=1)
    replies = []
    for _ in range(30):                                   # a steady turn: a settled drive
        replies.append(sim.command(velocity_line(150, 60, 400)))
        sim.run_for(0.05)
    for k in range(50):
        if k == 20:
            sim.sensors[1].lifted = True
        line = velocity_line(400, 50, 100 - 4 * k) if k % 5 else wheels_line([250, -300, 120])
        replies.append(sim.command(line))
        sim.run_for(0.05 + 0.003 * (k % 4))
    sim.run_for(1.2)                                      # the watchdog stops it
    replies.append(sim.read())
    if clock_events is not None:
        clock_events.append(sim.clock._seq)
    return (square, replies, sim.trace, sim.i2c, bytes(sim.notices), sim.world.pose,
            sim.world.t_s, sim.world.collisions, sim.core.sums, sim.core.polls,
            [(s._acc, s.lost, s._free_at, s._rng.getstate()) for s in sim.sensors],
            sim.drive.rims, sim.clock.now)


def test_the_sims_fused_central_tick_is_the_plain_path(starfish):
    """StarfishSim's central ticks in runs (fused_run.central_run: tick after tick in
    one call while nothing else is due), its one-tick _central_settled and its _account
    (the travel, inlined) against the plain methods: the same trace, bus, notices,
    poses, sums and generator states, in a room with walls, with noise, lag and slip;
    the runs take fewer clock events."""
    cases = [(lambda: World(pose=Pose(3800, 700, 0.2)), 0.02, 1),
             (lambda: World(pose=Pose(4300, 4300, 0.0)), 0.0, 2),
             (lambda: World(pose=Pose(3800, 700, 0.2),
                            options=WorldOptions(lag_s=0.05, slip=0.1, slip_noise=0.02, seed=4)),
              0.05, 7),
             (lambda: World(pose=Pose(1500, 2500, 0.5)), 0.01, 3)]     # turning, no wall
    walls = 0
    for make, noise, seed in cases:
        events: list[int] = []
        runs = _sim_run(starfish, "runs", make(), noise, seed, events)
        assert runs == _sim_run(starfish, "settled", make(), noise, seed, events)
        assert runs == _sim_run(starfish, "plain", make(), noise, seed)
        assert b"!W watchdog stop" in runs[4]
        assert events[0] < events[1] or make().options.lag_s > 0   # (lag: no runs)
        walls += runs[7]
    assert walls >= 2                                # the first two runs meet a wall


def _line_run(robot, plain: bool) -> tuple:
    """A seeded session of exchanges: commands and refusals, odometry polls, a line
    with a checksum, one too long, one with a bad byte, an empty one, raw bytes still
    on the wire when a command is sent, a timeout shorter than the line, and refused
    lines while the watchdog stops the robot (its notice during an exchange).
    ``plain``: every line onto the wire (SerialHost._send_line) and every reply line
    by line (_collect_lines)."""
    from esair_min.components.omni_base.core import velocity_line
    from esair_min.emulator.line import SerialHost
    from esair_min.emulator.starfish.robot_sim import FlowOptions, StarfishSim

    sim = StarfishSim(robot, World(pose=Pose(2500, 2500, 0.0)), FlowOptions(noise=0.02))
    if plain:
        sim._send_line = lambda data, end: SerialHost._send_line(sim, data, end)  # type: ignore[method-assign]
        sim._take_reply = lambda end: None                                         # type: ignore[method-assign]
    got = []
    lines = [velocity_line(200, -100, 300), "O", "v", "V+0200+0000+0000*5C", "Z",
             "V" + "+0001" * 12, "V+02\x070+0000+0000", "", "W+0100-0100+0100", "O", "x"]
    for k, line in enumerate(lines * 3):
        got.append(sim.exchange(line))
        sim.run_for(0.011 * (k % 5))
    sim.write(b"O\r\nv\r\n")                          # on the wire when the next is sent
    got.append(sim.exchange("O"))
    got.append(sim.exchange("V+0100+0000+0000", timeout_s=0.001))   # no reply in time
    sim.settle()
    got.append(sim.read())
    got.append(sim.exchange(velocity_line(300, 0, 0)))
    for _ in range(20):                                # refused: the watchdog fires
        got.append(sim.exchange("Q"))
        sim.run_for(0.03)
    got.append(sim.read())
    return (got, sim.trace, sim.i2c, bytes(sim.notices), sim.world.pose, sim.core.sums,
            sim.core.polls, sim.clock.now, sim.uart.rx_bytes, sim.uart.tx_bytes,
            sim.uart.overruns, sim.uart.rx_free_ns, sim.idle)


def test_the_sims_direct_line_and_reply_are_the_uarts_run(starfish):
    """StarfishSim._send_line (a line on a quiet link straight to the decoder at its CR)
    and SerialHost._take_reply (a reply alone on the wire in one run) against the line
    carried byte run by byte run through the UART and read line by line: the same
    replies, notices, times, trace, bus and counters."""
    fast = _line_run(starfish, False)
    assert fast == _line_run(starfish, True)
    replies = [g for g in fast[0] if isinstance(g, list)]
    assert ["!W watchdog stop", "E01 unknown command"] in replies   # during an exchange
    assert {"OK", "E01", "E02", "E06", "E13"} <= {r[-1][:3].rstrip() for r in replies if r}
    assert [] in replies                               # the timeout


def _plain_update(odo, sums, last, pose):
    """FlowOdometry.update as first written: sums of generators, _solve3 in full."""
    from esair_min.components.optical_flow.odometry import _solve3

    meas = []
    for k, ((sx, sy), (lx, ly)) in enumerate(zip(sums, last, strict=True)):
        meas += [(sx - lx) * odo.mm[k], (sy - ly) * odo.mm[k]]
    atb = [sum(r[i] * m for r, m in zip(odo.rows, meas, strict=True)) for i in range(3)]
    dx, dy, dth = _solve3(odo.ata, atb)
    x, y, theta = pose
    mid = theta + dth / 2
    return (x + (math.cos(mid) * dx - math.sin(mid) * dy),
            y + (math.sin(mid) * dx + math.cos(mid) * dy), theta + dth)


@PROPS
@given(polls=st.lists(st.lists(st.integers(-2**31, 2**31), min_size=4, max_size=4),
                      min_size=1, max_size=12),
       pose=st.tuples(st.floats(-5000, 5000), st.floats(-5000, 5000), st.floats(-7, 7)))
def test_the_odometrys_update_is_the_plain_least_squares(starfish, polls, pose):
    """FlowOdometry.update (the columns summed by map, the determinant of the constant
    matrix computed once) against the plain formulas: the same pose, float for float."""
    from esair_min.components.optical_flow.odometry import FlowOdometry

    odo = FlowOdometry(starfish.central.flow_sensors, *pose)
    last = [(0, 0), (0, 0)]
    odo.update(last)
    want = pose
    for p in polls:
        sums = [(p[0], p[1]), (p[2], p[3])]
        want = _plain_update(odo, sums, last, want)
        assert odo.update(sums) == want
        last = sums


def test_the_odometry_refuses_sums_of_another_count_of_sensors(starfish):
    from esair_min.components.optical_flow.odometry import FlowOdometry

    odo = FlowOdometry(starfish.central.flow_sensors)
    for sums in ([(0, 0), (0, 0), (0, 0)], [(0, 0)]):
        try:
            odo.update(sums)
        except ValueError as exc:
            assert str(exc) == f"sums of {len(sums)} flow sensors, not 2"
        else:
            raise AssertionError("no ValueError")
    odo.update([(0, 0), (0, 0)])
    try:
        odo.update([(5, 0)])
    except ValueError as exc:
        assert str(exc) == "sums of 1 flow sensors, not 2"
    else:
        raise AssertionError("no ValueError")


@PROPS
@given(picks=st.lists(st.tuples(st.integers(0, 99), st.booleans()), max_size=200))
def test_a_repeated_drive_lines_plan_is_the_line_parsed_again(starfish, picks):
    """StarfishCore's plans (a V/W line's refusal or drive write, kept by its body, all
    dropped past PLANS) against a core that parses every line: the same replies, bus
    writes and commanded speeds, over lines repeated and new, valid, outside the limits,
    malformed, and more than PLANS of them."""
    from esair_min.components.omni_base.core import PLANS, StarfishCore

    pool = ([f"V{vx:+05d}{vy:+05d}{w:+05d}" for vx in (-400, 0, 250, 2000)
             for vy in (-100, 0, 300) for w in (0, 500, -9000)]
            + [f"W{a:+05d}{b:+05d}{c:+05d}" for a in (0, 120, -700) for b in (0, 900)
               for c in (5, -5000)]
            + [f"V{k:+05d}+0000+0000" for k in range(40)] + ["V+01a0+0000+0000", "W+0000+0000-00 1"])
    assert len(pool) > PLANS
    writes: dict[str, list] = {"plans": [], "parsed": []}
    answer = [True]                                 # whether the drive board answers

    def bus(name: str):
        return lambda a, d: writes[name].append((a, d)) or answer[0]

    cores = {name: StarfishCore(starfish, bus(name)) for name in writes}
    for k, ok in picks:
        answer[0] = ok
        line = pool[k % len(pool)].encode()
        cores["parsed"]._plans.clear()              # the plain path: parsed every time
        assert cores["plans"].line(line) == cores["parsed"].line(line)
        assert cores["plans"].commanded == cores["parsed"].commanded
        assert len(cores["plans"]._plans) <= PLANS
    assert writes["plans"] == writes["parsed"]
