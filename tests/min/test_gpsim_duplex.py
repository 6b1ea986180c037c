"""Pipelined lines on PAPA-MAN's real central firmware in gpsim (issue 21, item 7).

The host link writes a command while the reply to a feet poll is still going out
(esair_std/drivers/minlink/link.py, "Full duplex"). That is sound only if the board
takes a line while it transmits: its receive ring is fed by the RX interrupt and its
replies leave from an interrupt-fed transmit ring, so the superloop decodes the next
line as soon as its CR is in, and answers in order. Shown here on the PIC18F452 build:
the servo command sent during the ``s`` reply is read, decoded and its servo written
before that reply has left the board, and every line gets its one reply, in order; the
emulator (which the link's tests use) answers the same. The overrun rule is unchanged
(tests/min/test_gpsim_uart.py, test_gpsim_overrun.py): the link never has more than two
lines unanswered, at most 64 bytes, so it cannot fill the 64-byte ring.
"""

from __future__ import annotations

import pytest

from esair_min.emulator import Emulator
from esair_min.pic.gpsim_harness import GpsimSetup, run_stimulus
from tests.support.board_lines import VERSION_OK_T

pytestmark = pytest.mark.gpsim

READING = 514            # a value gpsim's sensor stand-in can return (docs/toolchain.md)
FEET = "OK " + ",".join([str(READING)] * 8)
VERSION = VERSION_OK_T


def _lines(tx: list[tuple[int, int]]) -> list[tuple[int, int, str]]:
    """(cycle of the first byte, cycle of the LF, text) of every reply line sent."""
    out, start, buf = [], None, bytearray()
    for cycle, b in tx:
        start = cycle if start is None else start
        buf.append(b)
        if b == 0x0A:
            out.append((start, cycle, buf.decode("latin-1").rstrip("\r\n")))
            start, buf = None, bytearray()
    return [r for r in out if not r[2].startswith("!")]


def test_a_line_sent_while_a_reply_goes_out_is_decoded_at_once_and_answered_in_order(
        robot, pic_firmware, tmp_path):
    # s, then (a tick later: its reply is going out) a servo command; then v and,
    # during the v reply, a second servo command
    stimulus = (f"sensor {' '.join([str(READING)] * 8)}\nboot\ntick 1\n"
                "rx s\\r\\n\ntick 1\nrx odc100\\r\\n\ntick 8\n"
                "rx v\\r\\n\ntick 1\nrx odc110\\r\\n\ntick 12\n")
    cod = pic_firmware("central") / "build-pic" / "firmware.cod"
    run = run_stimulus(robot, stimulus, cod, tmp_path)
    replies = _lines(run.tx)
    assert [text for _, _, text in replies] == [FEET, "OK", VERSION, "OK"]

    setup = GpsimSetup.from_robot(robot)
    act = setup.actuator_address
    writes = [t.start for t in run.transfers
              if t.segments and t.segments[0].address == act and not t.segments[0].reading]
    assert len(writes) == 2
    crs = [c for c, b in run.rx if b == 0x0D]
    assert len(crs) == 4                                  # s, odc100, v, odc110
    (s_first, s_lf, _), (o_first, _, _), (v_first, v_lf, _), (o2_first, _, _) = replies
    for long_first, long_lf, cr, write, ok_first in ((s_first, s_lf, crs[1], writes[0], o_first),
                                                     (v_first, v_lf, crs[3], writes[1], o2_first)):
        # the command's CR was read while the long reply was going out ...
        assert long_first < cr < long_lf
        # ... its servo written at the next tick, before that reply had left ...
        assert cr < write < long_lf
        # ... and its OK queued behind it, not before
        assert ok_first > long_lf

    # the emulator answers the same lines the same way
    emu = Emulator(robot)
    emu.settle()
    emu.read()
    emu.sensor_slave.set_readings((READING,) * 8)
    tick = setup.tick_cycles / setup.cycles_per_second
    for line, ticks in ((b"s\r\n", 1), (b"odc100\r\n", 8), (b"v\r\n", 1), (b"odc110\r\n", 12)):
        emu.write(line)
        emu.run_for(ticks * tick)
    got = [r for r in emu.read().decode("latin-1").split("\r\n")[:-1] if not r.startswith("!")]
    assert got == [FEET, "OK", VERSION, "OK"]
