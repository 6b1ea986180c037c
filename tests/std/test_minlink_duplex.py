"""The MIN link is full duplex (issue 21, item 7): a command goes out while the robot's
reply to a feet poll is still arriving, commands go before polls, and replies stay
matched in order, on a noisy line too.

Against the emulator (its UART takes a line while a reply goes out, as the PIC's
interrupt-fed rings do: tests/min/test_gpsim_duplex.py shows it on the firmware):
in-process (esair://, a trace in virtual time) and behind a real pty (SIGSTOP to hold
the robot's answer back).
"""

from __future__ import annotations

import os
import signal
import threading
import time
from pathlib import Path

import pytest

from esair_min.model.validate import load_robot
from esair_std.drivers.minlink import Exchange, Link, LinkDown, RobotRefused
from esair_std.drivers.minlink.emulated import EmulatedRobot
from esair_std.drivers.minlink.link import OUT_OF_STEP, WIRE_CODES

pytestmark = pytest.mark.pty

ROOT = Path(__file__).resolve().parents[2]
PAPAMAN = ROOT / "boards" / "papaman"
URL = f"esair://{PAPAMAN}"


@pytest.fixture(scope="module")
def robot():
    return load_robot(PAPAMAN)


def _wait(cond, what: str, seconds: float = 10.0) -> None:
    end = time.monotonic() + seconds
    while not cond():
        if time.monotonic() > end:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.0005)


def _in_thread(fn) -> tuple[threading.Thread, dict]:
    out: dict = {}

    def run() -> None:
        try:
            out["ex"] = fn()
        except Exception as exc:  # noqa: BLE001 - handed to the test
            out["error"] = exc
    t = threading.Thread(target=run)
    t.start()
    return t, out


def _marks(trace: Path) -> tuple[list[tuple[float, bytes]], list[float]]:
    """(virtual ms the board sent it, reply) of every TX, and the virtual ms of every
    servo register write (``W 10`` of one servo pair) in ``trace``."""
    tx, writes, mark = [], [], 0.0
    for line in trace.read_text().splitlines():
        if line.startswith("@ "):
            mark = int(line[2:]) / 1e3
        elif line.startswith("TX "):
            tx.append((mark, bytes.fromhex(line[3:])))
        elif line.startswith("W 10 ") and len(line.split()[2]) == 6:
            writes.append(mark)
    return tx, writes


@pytest.mark.parametrize("duplex", [True, False])
def test_a_servo_moves_while_the_feet_reply_is_still_arriving(tmp_path, robot, duplex):
    """A feet poll is in flight; a servo command then goes out at once (duplex) and the
    robot writes the servo register before the poll's reply has left it; with
    ``duplex=False`` the command waits for that reply, the write comes after its end."""
    trace = tmp_path / "t.txt"
    with Link(robot, f"{URL}?trace={trace}", duplex=duplex) as link:
        t, out = _in_thread(lambda: link.exchange("s", poll=True))
        _wait(lambda: link.in_flight == 1, "the poll in flight")
        motor = link.exchange("odc100")
        t.join(5)
        poll: Exchange = out["ex"]
        stats = dict(link.stats)
    assert len(poll.data.split(",")) == 8 and motor.data == ""
    assert poll.t_sent < motor.t_sent and poll.t_reply < motor.t_reply     # in order
    assert stats["ok"] == 2 and stats.get("strays", 0) == 0
    tx, writes = _marks(trace)
    (sent_at, reply), = [(t0, r) for t0, r in tx if r.startswith(b"OK ") and b"," in r]
    reply_end = sent_at + len(reply) * 10 / robot.central.uart.baud * 1e3
    assert len(writes) == 1
    if duplex:
        assert stats["duplex"] == 1 and motor.t_sent < poll.t_reply
        assert writes[0] < reply_end, (writes, sent_at, reply_end)
    else:
        assert stats.get("duplex", 0) == 0 and motor.t_sent >= poll.t_reply
        assert writes[0] > reply_end, (writes, sent_at, reply_end)


def test_commands_go_before_polls_and_nothing_more_goes_to_a_robot_that_does_not_answer(
        robot):
    """The robot is held (SIGSTOP) with a ``v`` in flight: a poll and then a command
    wait (nothing more is written to a robot that does not answer). Resumed, its ``v``
    reply begins: the command goes out beside it first; the poll waits for room."""
    with EmulatedRobot(PAPAMAN) as emu, Link(robot, emu.port, timeout=2.0) as link:
        link.stand()
        os.kill(emu.proc.pid, signal.SIGSTOP)
        try:
            tv, v = _in_thread(lambda: link.exchange("v"))
            _wait(lambda: link.in_flight == 1 and link.stats["sent"] == 2, "the v written")
            tp, p = _in_thread(lambda: link.exchange("s", poll=True))
            _wait(lambda: link.waiting == 1, "the poll waiting")
            tc, c = _in_thread(lambda: link.exchange("x"))
            _wait(lambda: link.waiting == 2, "the command waiting")
            assert link.in_flight == 1 and link.stats["sent"] == 2, (
                link.in_flight, dict(link.stats))               # stand, v
        finally:
            os.kill(emu.proc.pid, signal.SIGCONT)
        for t in (tv, tp, tc):
            t.join(10)
        stats = dict(link.stats)
    assert v["ex"].data.startswith("esair-min/1 ") and c["ex"].data == ""
    assert len(p["ex"].data.split(",")) == 8
    assert v["ex"].t_sent < c["ex"].t_sent < v["ex"].t_reply    # beside the v reply
    assert c["ex"].t_sent < p["ex"].t_sent                       # before the poll
    assert p["ex"].t_sent >= v["ex"].t_reply                     # two in flight at most
    assert stats["duplex"] >= 1 and stats["ok"] == 4 and stats.get("strays", 0) == 0


def test_line_noise_never_mismatches_a_reply_with_two_in_flight(robot):
    """Random bytes on the robot's receive line while a poller and a commander share
    the link: every ``OK`` has the shape of its own command, every refusal names a
    damaged line's code and its own command; what the link cannot match it gives up
    on (down, then back), never passing one reply for another."""
    shapes = {"v": lambda d: d.startswith("esair-min/1 servos=12"),
              "s": lambda d: len(d.split(",")) == 8, "x": lambda d: d == ""}
    bad: list[str] = []
    codes: list[str] = []
    downs: list[str] = []
    with Link(robot, URL + "?noise=15&seed=11", timeout=0.5) as link:
        def run(lines: list[str], poll: bool) -> None:
            for line in lines:
                try:
                    data = link.command(line, poll=poll)
                except RobotRefused as exc:
                    codes.append(exc.code)
                    if exc.command != line or exc.code not in WIRE_CODES:
                        bad.append(f"{line}: {exc}")
                    continue
                except LinkDown as exc:
                    downs.append(str(exc))
                    _wait(lambda: link.up, "the link back")
                    continue
                if not shapes[line](data):
                    bad.append(f"{line}: OK {data}")
        threads = [threading.Thread(target=run, args=(["s"] * 30, True)),
                   threading.Thread(target=run, args=(["v", "x"] * 15, False))]
        for t in threads:
            t.start()
        for t in threads:
            t.join(60)
        stats = dict(link.stats)
    assert bad == [], bad
    assert stats["duplex"] > 5 and codes, stats
    assert all(OUT_OF_STEP in d or "no reply" in d for d in downs), downs
