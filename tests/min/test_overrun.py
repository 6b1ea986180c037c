"""A line that lost bytes in a receive overrun moves nothing (issue 10, item 1).

The receive ring marks a loss where it happened (the first byte in after it carries
the mark); lines that ended before the loss run, the damaged line (its start, the gap,
up to the next line end) is answered E12 once, whole lines inside the loss are gone.
Here: the Python harness and core on fixed scripts (tests/fixtures/overrun/), a
hypothesis property over streams that overrun the ring, and the emulator. The host C
build and the PIC in gpsim run the same scripts in test_differential.py and
test_gpsim_overrun.py.
"""

from __future__ import annotations

import pytest

from pathlib import Path

from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from esair_min.core.stimulus import Rig, run_line, run_script, unescape
from esair_min.core.protocol import MAX_LINE
from esair_min.core.trace import TraceWriter
from esair_min.emulator import Emulator
from esair_min.emulator.uart import GAP, RING_BYTES
from esair_min.model.validate import load_robot
from tests.support.overrun_streams import burst, scripts
from tests.support.board_lines import READY_OK_T, VERSION_OK_T, text, version

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
FIXTURES = ROOT / "tests" / "fixtures" / "overrun"
PAPAMAN = load_robot(ROOT / "boards" / "papaman")
STAND = "W 10 00" + "5A14" * 12 + " ACK"
VERSION = VERSION_OK_T
E12 = "E12 input overrun"
PROPERTY_EXAMPLES = 400
CR, LF = 0x0D, 0x0A


def replies(trace: list[str]) -> list[str]:
    return [bytes.fromhex(line[3:]).decode().rstrip("\r\n") for line in trace
            if line.startswith("TX ")]


def actuator_writes(trace: list[str]) -> list[str]:
    return [line for line in trace if line.startswith("W 10 ")]


# -- the fixed scripts ------------------------------------------------------------------

def test_issue_reproducer_moves_nothing_from_the_damaged_line():
    """Issue 10's reproducer: before the fix the first, intact v got E12 and
    cTTTTTTTTT + SIT ran (servos to angles nobody sent)."""
    trace = run_script(PAPAMAN, (FIXTURES / "issue10.txt").read_text())
    assert replies(trace) == [READY_OK_T, "OK"] + [VERSION] * 27 + [E12]
    assert actuator_writes(trace) == [STAND]                    # t's write only
    gpsim_version = run_script(PAPAMAN, (FIXTURES / "issue10_gpsim.txt").read_text())
    assert replies(gpsim_version) == replies(trace)
    assert actuator_writes(gpsim_version) == [STAND]


def test_gaps_script_losses_after_a_line_end_mid_line_and_twice():
    trace = run_script(PAPAMAN, (FIXTURES / "gaps.txt").read_text())
    assert replies(trace) == [
        READY_OK_T,
        "OK", "OK", E12, VERSION,          # 1. t, x; the LF after the gap; v
        "OK", E12, "OK",                    # 2. t; oab<gap>TTTTTTTTTT; x
        "OK", "OK", E12, "OK", E12, "OK",   # 3. oab100, oac100; x<gap>; t; xxxx<gap>PLY01; x
    ]
    assert actuator_writes(trace) == [STAND, STAND, "W 10 00000B ACK", "W 10 000015 ACK",
                                      STAND]


def test_a_loss_at_the_end_of_a_burst_damages_the_next_line():
    """The board cannot know whether the lost bytes ended with a line end: the bytes
    after the gap up to the next line end are the damaged line's tail."""
    rig = Rig(PAPAMAN)
    rig.boot()
    rig.rx(b"t\r" + b"\r" * 64 + b"x\r")      # x's line is lost whole
    rig.tick()
    at = len(rig.writer.lines)
    rig.rx(b"v\r")
    rig.rx(b"v\r")
    assert replies(rig.writer.lines[at:]) == [E12, VERSION]


# -- the property ------------------------------------------------------------------------

class Oracle:
    """Follows every byte from the script to the decoder, independently of the core's
    own overrun handling: which sent bytes the ring dropped (Rig.dropped), which byte
    the decoder is fed, where each line starts and ends. It checks, for every line the
    decoder finishes, that it runs (reaches the command table) exactly when it arrived
    whole (no byte lost from its start to its line end, terminator included), and for
    every actuator write, that it comes from such a line (or from the reaction)."""

    def __init__(self, core, bus, actuator: int, dropped: list[int]):
        self.core = core
        self.actuator = actuator
        self.dropped = dropped           # indexes in ``sent`` of the bytes the ring lost
        self.sent = bytearray()          # every byte offered to the ring, in order
        self.pos = -1                    # index of the byte fed last
        self.boundary = -1               # index of the line end fed last (or the boot)
        self.origin: object = None       # the line being run (or "reaction")
        self.held_origin: object = None  # the line whose write waits for the tick
        self.motion_origin: object = None
        self.tick_held = False
        self.executed = 0
        self.writes = 0
        self._rx_byte, self._line, self._tick = core.rx_byte, core._line, core.tick
        self._start, self._write = core._player.start, bus.write
        core.rx_byte, core._line, core.tick = self.rx_byte, self.line, self.tick
        core.rx_run = self.rx_run
        core._player.start, bus.write = self.start, self.write

    @classmethod
    def of(cls, rig: Rig) -> Oracle:
        return cls(rig.core, rig.bus, rig.actuator.address, rig.dropped)

    def boot(self, received: int) -> None:
        """The ring was emptied after ``received`` bytes and the core reset."""
        self.pos = self.boundary = received - 1
        self.held_origin = self.motion_origin = None

    def rx_run(self, data: bytes) -> None:
        for b in data:               # the core's contract: rx_byte of each in turn
            self.rx_byte(b)

    def rx_byte(self, b: int) -> None:
        dropped = set(self.dropped)
        j = self.pos + 1
        while j in dropped:
            j += 1
        assert self.sent[j] == b, "the oracle lost track of the stream"
        self.pos = j
        self._rx_byte(b)
        if b in (CR, LF):
            self.boundary = j

    def intact(self) -> bool:
        """No byte lost from the line's start through its end (the byte fed last)."""
        return not any(self.boundary < d <= self.pos for d in self.dropped)

    def line(self, result) -> None:
        whole = self.intact()
        if isinstance(result, bytes):            # the line reaches the command table
            self.executed += 1
            assert whole, f"line {result!r} ran though bytes of it were lost"
            assert bytes(self.sent[self.boundary + 1:self.pos]) == result
        else:
            text = bytes(self.sent[self.boundary + 1:self.pos])
            if whole and 0 < len(text) <= MAX_LINE and all(0x20 <= c <= 0x7E for c in text):
                raise AssertionError(f"whole line {text!r} was refused with {result!r}")
        self.origin = ("line", self.pos, whole)
        before = self.core._held
        self._line(result)
        if before is None and self.core._held is not None:
            self.held_origin = self.origin
        self.origin = None

    def start(self, number: int, frames: int, delay: int, offset: int) -> bool:
        self.motion_origin = self.origin or "reaction"
        return self._start(number, frames, delay, offset)

    def tick(self) -> None:
        self.tick_held = self.core._held is not None
        self._tick()
        self.tick_held = False

    def write(self, addr: int, data: bytes) -> bool:
        if addr == self.actuator:
            if self.tick_held:
                origin, self.held_origin, self.tick_held = self.held_origin, None, False
            else:
                origin = self.motion_origin
            assert origin == "reaction" or (origin is not None and origin[2]), \
                f"actuator write {data.hex()} from {origin}"
            self.writes += 1
        return self._write(addr, data)


def run_with_oracle(lines: list[str], rig: Rig | None = None) -> Oracle:
    rig = Rig(PAPAMAN) if rig is None else rig
    oracle = Oracle.of(rig)
    for line in lines:
        if line == "boot":
            rig.boot()
            oracle.boot(rig.received)
        elif line.startswith("rx "):
            data = unescape(line[3:])
            oracle.sent += data
            rig.rx(data)
        else:
            run_line(rig, line, ROOT)
    return oracle


@settings(max_examples=PROPERTY_EXAMPLES, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(scripts)
def test_no_actuator_write_from_a_line_that_lost_bytes(steps):
    """For any command stream with any bytes dropped at ring overflow: a line runs
    exactly when it arrived whole, and every actuator write comes from such a line."""
    oracle = run_with_oracle(steps)
    event("bytes lost" if oracle.dropped else "no loss")


def test_the_property_sees_losses_and_would_catch_the_old_rule():
    """The streams really overrun the ring, and the oracle fails the pre-fix rule
    (the loss charged to the line the decoder happens to be in)."""
    steps = ["boot", "rx " + "t\\r" + "v\\r" * 27 + "cTTTTTTTTTTTT\\r", "tick", "rx SIT\\r",
             "tick 2"]
    oracle = run_with_oracle(steps)
    assert oracle.dropped and oracle.executed == 27 + 1 and oracle.writes == 1

    class OldRig(Rig):
        def feed(self) -> None:                   # the flag, told before the next byte
            while self.ring and self.core.ready():
                b = self.ring.popleft()
                if self.lost or b & 0x100:
                    self.lost = False
                    self.core.rx_overrun()
                self.core.rx_byte(b & 0xFF)

    try:
        run_with_oracle(steps, OldRig(PAPAMAN))
    except AssertionError as exc:
        assert "refused" in str(exc) or "ran though" in str(exc)
    else:
        raise AssertionError("the oracle accepted the old rule")


# -- the emulator -----------------------------------------------------------------------

def test_emulator_ring_marks_the_first_byte_in_after_a_loss(robot):
    emu = Emulator(robot)
    emu.settle()
    for _ in range(RING_BYTES + 3):
        emu.uart.receive(ord("v"))          # 3 lost
    assert emu.uart.overrun and emu.uart.overruns == 3
    assert not any(b & GAP for b in emu.uart.ring)
    emu.uart.ring.popleft()
    emu.uart.receive(ord("\r"))
    assert emu.uart.ring[-1] == GAP | 0x0D and not emu.uart.overrun


def test_emulator_reproducer_at_115200_baud(fast_robot):
    """The reproducer's bytes on the emulated line at 115200 baud (64 bytes arrive
    within the tick the held t waits for): the same replies as the Python harness and
    the PIC in gpsim, and the servos move only for t."""
    trace = TraceWriter(None)
    emu = Emulator(fast_robot, trace=trace)
    emu.settle()
    emu.read()
    # the burst starts an eighth of a tick after a tick, as the gpsim harness's (its boot
    # wait ends so): the held t then waits most of a tick while the bytes come in
    period = fast_robot.central.timer2.period_s
    emu.run_until(int((int(emu.now_s / period) + 1.125) * period * 1e9))
    emu.write(b"t\r" + b"v\r" * 27 + b"cTTTTTTTTTTTT\r")
    emu.run_for(0.3)
    emu.write(b"SIT\r")
    emu.run_for(0.3)
    lines = emu.read().decode().split("\r\n")
    assert lines == ["OK"] + [text(version(fast_robot))] * 27 + [E12, ""]
    assert emu.uart.overruns == 4                       # TTT and the CR
    assert actuator_writes(trace.lines) == [STAND]
    assert emu.playing is None


EMULATOR_EXAMPLES = 150


@settings(max_examples=EMULATOR_EXAMPLES, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                 HealthCheck.function_scoped_fixture])
@given(st.lists(st.tuples(burst, st.integers(0, 40)), min_size=1, max_size=8))
def test_emulator_no_actuator_write_from_a_line_that_lost_bytes(fast_robot, steps):
    """The same property on the emulated robot at 115200 baud, where bytes are lost
    both while a write is held and while replies slower than the line stall the
    superloop: bursts written at once, then some milliseconds of virtual time."""
    emu = Emulator(fast_robot)
    emu.settle()
    emu.uart.dropped = []
    oracle = Oracle(emu.core, emu.core.bus, emu.actuator_slave.address, emu.uart.dropped)
    oracle.boot(0)
    for data, ms in steps:
        oracle.sent += data
        emu.write(data)
        emu.run_for(ms / 1000)
    emu.run_for(1.0)
    event("bytes lost" if oracle.dropped else "no loss")
