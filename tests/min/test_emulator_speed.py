"""Pieces added for the emulator's speed (issue 5): a streaming trace writer, the
core's run feed, and the emulator's fast paths giving the same trace as slow ones."""

from __future__ import annotations

import io
from pathlib import Path

from hypothesis import given, settings, strategies as st

from esair_min.core.central import CentralCore
from esair_min.core.devices import Eeprom24, RegisterSlave, SimpleBus
from esair_min.emulator import Emulator
from esair_min.emulator.tracefile import FileTraceWriter
from esair_min.core.image import build_image
from esair_min.core.trace import HEADER, TraceWriter, TracingBus
from esair_min.model.validate import load_robot

ROOT = Path(__file__).resolve().parents[2]
PAPAMAN = load_robot(ROOT / "boards" / "papaman")
WORDS = [b"PLY03", b"oab100", b"mab123", b"s", b"v", b"S", b"P", b"K",
         b"a" + b"002" * 12, b"x" * 45, b"\x01", b"\r", b"\n", b"\r\n"]


def _drive(tw: TraceWriter) -> None:
    tw.tick(1)
    tw.tx(b"OK\r")
    tw.tx(b"\n!E")
    tw.write(0x10, b"\x00\x01", True)
    tw.read(0x50, b"\x00\x00", 2, None)
    tw.mark(123)
    tw.close()


def test_streaming_trace_writer_writes_every_line_and_keeps_only_the_header():
    kept, streamed = io.StringIO(), io.StringIO()
    full = TraceWriter(kept)
    _drive(full)
    lean = TraceWriter(streamed, keep=False)
    _drive(lean)
    assert streamed.getvalue() == kept.getvalue() == full.text()
    assert full.lines[0] == HEADER and len(full.lines) == 7
    assert lean.lines == [HEADER]
    file_writer = FileTraceWriter(io.StringIO())
    _drive(file_writer)
    assert file_writer.stream.getvalue() == full.text() and file_writer.lines == [HEADER]
    dropped = TraceWriter(keep=False)          # no stream: formatted, then dropped
    _drive(dropped)
    assert dropped.lines == [HEADER]


def _core() -> tuple[CentralCore, TraceWriter]:
    writer = TraceWriter()
    eep, act, sen = PAPAMAN.eeprom, PAPAMAN.peer("actuator"), PAPAMAN.peer("sensor")
    devices = [Eeprom24(eep.size_bytes, eep.address, eep.address_bytes,
                        build_image(PAPAMAN)),
               RegisterSlave(act.address, act.registers),
               RegisterSlave(sen.address, sen.registers)]
    core = CentralCore(PAPAMAN, TracingBus(SimpleBus(devices), writer), writer.tx)
    core.boot()
    return core, writer


@settings(max_examples=100, deadline=None)
@given(st.lists(st.tuples(st.lists(st.sampled_from(WORDS), max_size=5).map(b"".join),
                          st.integers(0, 2)), max_size=10))
def test_rx_run_is_rx_byte_of_each(script):
    one, w1 = _core()
    run, w2 = _core()
    for data, ticks in script:
        for b in data:
            one.rx_byte(b)
        run.rx_run(data)
        assert (one.line_length, one.ready(), one.playing) == \
               (run.line_length, run.ready(), run.playing)
        for _ in range(ticks):
            one.tick()
            run.tick()
    assert w1.lines == w2.lines


def _trace(fast: bool) -> list[str]:
    """A dance with commands at line rate; ``fast=False`` turns the UART fast paths off
    (every byte lands in the ring at its own time)."""
    tw = TraceWriter()
    emu = Emulator(PAPAMAN, scenario="push", trace=tw)
    if not fast:
        emu.uart._rx_mode = None
    emu.settle()
    mix = [b"PLY03\r\n", b"oab100\r\n", b"s\r\n", b"a" + b"002" * 12 + b"\r\n", b"S\n",
           b"x\x01\r", b"v\r\n", b"y" * 50 + b"\r\n"]
    for k in range(60):
        emu.write(mix[k % len(mix)])
        emu.run_for(0.013 * (k % 3))
    emu.run_for(1.0)
    emu.close()
    return tw.lines


def test_uart_fast_paths_give_the_same_trace_as_byte_by_byte():
    fast, slow = _trace(True), _trace(False)
    assert len(fast) > 500 and fast == slow
