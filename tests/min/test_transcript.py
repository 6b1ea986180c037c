"""The live view's serial line: each line as the decoder got it, with its own reply."""

from __future__ import annotations

from tests.support.board_lines import ready, text, version

from esair_min.emulator import Emulator
from esair_min.emulator.transcript import Row, Transcript
from esair_min.emulator.uart import GAP


def test_replies_pair_with_their_lines_and_notices_stand_apart():
    t = Transcript()
    t.board_line("!READY esair-min/1 image=ok")
    t.rx(b"v\r\nPLY03\r")
    t.board_line("OK esair-min/1")
    t.board_line("!R auto_balance")                 # between a line and its reply
    t.rx(b"\n\r\n")                                  # empty lines get no reply
    t.board_line("OK")
    t.rx(b"x\n")
    assert list(t.rows) == [Row("notice", "!READY esair-min/1 image=ok"),
                            Row("line", "v", "OK esair-min/1"),
                            Row("line", "PLY03", "OK"),
                            Row("notice", "!R auto_balance"),
                            Row("line", "x", None)]     # its reply has not come yet


def test_a_line_that_lost_bytes_shows_where():
    t = Transcript()
    for b in b"cTTT":
        t.rx_byte(b)
    for b in b"SIT\r":
        t.rx_byte(b | GAP if b == ord("S") else b)
    t.board_line("E12 input overrun")
    t.rx(b"\x07t\r")
    t.board_line("E13 bad character")
    assert list(t.rows) == [Row("line", "cTTT⋯SIT", "E12 input overrun"),
                            Row("line", "\\x07t", "E13 bad character")]


def test_the_emulator_keeps_the_transcript(robot):
    assert Emulator(robot).transcript is None          # off unless asked for (speed)
    emu = Emulator(robot, scenario="push", transcript=True)
    emu.settle()
    for line in ("v", "PLY03", "PLY01", "x"):
        emu.command(line)
    rows = [(r.kind, r.text, r.reply) for r in emu.transcript.rows]
    assert rows[0] == ("notice", text(ready(robot)), None)
    assert [r[1:] for r in rows[1:]] == [
        ("v", text(version(robot))),
        ("PLY03", "OK"), ("PLY01", "E07 busy"), ("x", "OK")]
