"""``esair emulate starfish``: served on a real pty (driven with pySerial and with ``esair
send``), run headless, its trace, and the options it refuses."""

from __future__ import annotations

import contextlib
import math
import os
import select
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import serial
from click.testing import CliRunner

from esair_min.cli import main
from esair_min.emulator.starfish.pose_trace import read_trace
from tests.support.robot_ptys import open_pty

pytestmark = pytest.mark.pty

ROOT = Path(__file__).resolve().parents[2]
START_TIMEOUT = 30
VERSION = "OK esair-min/1 starfish wheels=3 flow=2 watchdog=500 checksum=off"


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    return env


@contextlib.contextmanager
def emulator(*args: str):
    proc = subprocess.Popen(
        [sys.executable, "-m", "esair_min.cli", "emulate", "starfish", "--pty", *args],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=_env())
    try:
        ready, _, _ = select.select([proc.stdout], [], [], START_TIMEOUT)
        assert ready, "the emulator printed no pty path"
        path = proc.stdout.readline().decode().strip()
        assert path.startswith("/dev/"), path
        yield proc, path
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=10) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=10)
        proc.stdout.close()
        proc.stderr.close()


def ask(port: serial.Serial, line: str) -> str:
    """Send a line, return its reply (skipping the boot's !READY, which the port carries
    only if it was opened in time)."""
    port.write(line.encode() + b"\r\n")
    while True:
        got = port.readline()
        assert got.endswith(b"\r\n"), f"no reply to {line!r} (got {got!r})"
        if got != b"!READY esair-min/1 starfish\r\n":
            return got.decode().rstrip("\r\n")


def test_driven_over_the_pty_until_the_watchdog_stops_it(tmp_path):
    trace = tmp_path / "starfish.trace"
    # real time: the second O must come within the watchdog's 500 ms of the first even
    # on a loaded machine (a faster --speed leaves it too little wall time)
    with emulator("--trace", str(trace), "--instance", "0badcafe") as (_, path), \
            open_pty(path, 38400, timeout=5) as port:
        assert ask(port, "v") == VERSION + " id=0badcafe"
        assert ask(port, "V+0200+0000+0000") == "OK"
        first = ask(port, "O")
        time.sleep(0.1)
        second = ask(port, "O")
        assert first.startswith("OK n=") and second.startswith("OK n=")
        moved = int(second.split()[2].split("=")[1].split(",")[0])
        assert moved > 0                                  # the left flow sensor counted
        assert port.readline() == b"!W watchdog stop\r\n"   # nothing sent for 500 ms
        time.sleep(0.3)                                   # ramped down in 0.1 s
    rows = read_trace(trace)
    assert len(rows.room.walls) == 4 and rows.t == sorted(rows.t)
    assert max(rows.x) > 2550 and rows.wheels[-1] == (0.0, 0.0, 0.0)


def test_esair_send_drives_it():
    with emulator("--instance", "0badcafe") as (_, path):
        run = subprocess.run(
            [sys.executable, "-m", "esair_min.cli", "send", path, "v", "W+0100+0100+0100",
             "x", "V+0900+0000+0000", "t"],
            cwd=ROOT, env=_env(), capture_output=True, timeout=60)
        assert run.stdout.decode().splitlines() == [
            VERSION + " id=0badcafe", "OK", "OK", "E04 outside limits", "E01 unknown command"]
        assert run.returncode == 1


def test_headless_run_prints_the_replies_and_the_pose(tmp_path):
    result = CliRunner().invoke(main, ["emulate", "starfish", "--run", "2", "--send",
                                       "V+0000+0200+0000", "--send", "v"])
    assert result.exit_code == 0, result.output
    assert result.stdout.splitlines() == ["!READY esair-min/1 starfish", "OK", VERSION,
                                          "!W watchdog stop"]
    assert result.stderr.startswith("pose after 2 s: x 2500.")
    assert ", y 2598." in result.stderr and result.stderr.endswith(
        "wall contacts 0; drive writes 2 (0 dropped from the record of the last 1024)\n")


def test_room_file_and_refused_options(tmp_path):
    room = Path("tests/fixtures/rooms/lab.yaml")
    result = CliRunner().invoke(main, ["emulate", "starfish", "--run", "0.1", "--room",
                                       str(room)])
    assert result.exit_code == 0
    assert "pose after 0.1 s: x 3000.0 mm, y 2000.0 mm" in result.stderr
    for args, message in [
        (["--scenario", "push"], "--scenario: not for a robot with an omni base (STARFISH), "
         "whose sensors and faults are its room's (docs/emulator.md)"),
        (["--stuck-bus"], "the fault options: not for a robot with an omni base (STARFISH), "
         "whose sensors and faults are its room's (docs/emulator.md)"),
    ]:
        result = CliRunner().invoke(main, ["emulate", "starfish", "--run", "1", *args])
        assert (result.exit_code, result.stderr) == (1, f"error: {message}\n")
    result = CliRunner().invoke(main, ["emulate", "papaman", "--run", "1", "--room",
                                       str(room)])
    assert (result.exit_code, result.stderr) == (
        1, "error: --room is for a robot with an omni base (STARFISH); this robot has none\n")


def test_generate_first(tmp_path):
    result = CliRunner().invoke(main, ["emulate", "starfish", "--run", "0.1", "--generate",
                                       str(tmp_path / "fw")])
    assert result.exit_code == 0
    assert result.stderr.startswith(f"generated starfish into {tmp_path / 'fw'}\n")
    assert (tmp_path / "fw" / "drive" / "core" / "drive.c").is_file()


def test_trace_and_plot_of_a_headless_run(tmp_path):
    trace, png = tmp_path / "run.trace", tmp_path / "run.png"
    result = CliRunner().invoke(main, ["emulate", "starfish", "--run", "1", "--trace",
                                       str(trace), "--send", "V+0300+0000+0000"])
    assert result.exit_code == 0
    tr = read_trace(trace)
    assert len(tr.t) == 100 and tr.t[-1] == 0.999040     # ticks of 9.9904 ms
    assert tr.x[-1] > 2600 and tr.contacts == []
    result = CliRunner().invoke(main, ["plot", str(trace), "-o", str(png)])
    assert (result.exit_code, result.output) == (0, f"100 ticks -> {png}\n")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    trace.write_text("# esair-starfish-trace 1\n@1.0 2 3\n")
    result = CliRunner().invoke(main, ["plot", str(trace), "-o", str(png)])
    assert (result.exit_code, result.stderr) == (
        1, f"error: {trace}:2: not a STARFISH trace line: '@1.0 2 3'\n")


def test_live_view_draws_the_room_and_the_robot(starfish):
    from esair_min.emulator.ptyserver import PtyPort
    from esair_min.emulator.starfish.robot_sim import StarfishSim
    from esair_min.emulator.starfish.view import render
    from esair_min.world import Pose, Room, World

    sim = StarfishSim(starfish, World(room=Room.box(2000, 1000), pose=Pose(500, 500, 1.6)))
    assert sim.command("V+0200+0000+0000") == "OK"
    sim.run_until(300_000_000)          # 0.3 s from reset (the line and its OK took 5.7 ms)
    lines = render(sim, PtyPort(path="/dev/pts/9", open=True), 30, 10)
    wide = render(sim, PtyPort(path="/dev/pts/9", open=True), 200, 10)
    assert wide[2].endswith("   drive writes 1 (0 dropped from the record)")
    assert lines == [
        "STARFISH  t     0.30 s  port /",
        "pose x   498.0 mm  y   549.9 m",
        "wheels (mm/s)   -198     +98  ",
        "",
        "#####################",
        "#                   #",
        "#    ^              #",
        "#                   #",
        "#                   #",
        "#####################",
    ]


def test_the_world_out_socket_gets_the_true_pose_from_the_start_pose(tmp_path):
    """--pose places the robot, --world-out sends its true pose each central tick to a
    Unix datagram socket (what the host's simulated sensors render from); a robot on a
    pty answers v with a random id= of its boot."""
    import socket

    from esair_min.emulator.world_out import parse_datagram

    sock_path = str(tmp_path / "world.sock")
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    sock.bind(sock_path)
    sock.settimeout(5)
    with sock, emulator("--pose", "1000,1500,0.5", "--world-out", sock_path) as (_, path), \
            open_pty(path, 38400, timeout=5) as port:
        reply = ask(port, "v")
        assert reply.startswith(VERSION + " id=") and len(reply.split("id=")[1]) == 8
        t, x, y, th, hits = parse_datagram(sock.recv(256))
        assert (x, y, th, hits) == (1000.0, 1500.0, 0.5, 0)
        assert ask(port, "V+0200+0000+0000") == "OK"
        while True:                                # the robot moves along its heading
            t2, x2, y2, th2, _ = parse_datagram(sock.recv(256))
            if x2 > 1010:
                break
        assert t2 > t and math.atan2(y2 - y, x2 - x) == pytest.approx(0.5, abs=0.05)
    assert parse_datagram(b"pose 1 2") is None and parse_datagram(b"pose a b c d e") is None


@pytest.mark.parametrize("args, message", [
    (["--pose", "10,1000,0"], "error: --pose 10,1000: the robot (radius 150 mm) would stand in a wall"),
    (["--pose", "1,2"], "Error: Invalid value for '--pose': '1,2' is not X,Y,THETA (mm, mm, rad)"),
])
def test_a_bad_pose_is_refused(args, message):
    result = CliRunner().invoke(main, ["emulate", "starfish", "--run", "0.1", *args])
    assert result.exit_code != 0
    assert result.output.strip().splitlines()[-1] == message


def test_world_out_and_pose_are_for_an_omni_base_only():
    result = CliRunner().invoke(main, ["emulate", "papaman", "--run", "0.1", "--pose", "1,2,3"])
    assert result.output.strip().splitlines()[-1] == (
        "error: --pose is for a robot with an omni base (STARFISH); this robot has none")
    result = CliRunner().invoke(main, ["emulate", "starfish", "--run", "0.1", "--world-out", "w"])
    assert result.output.strip().splitlines()[-1] == "error: --world-out works with --pty only"
