"""`esair send`: one reply per command, notices on request, exit status, errors."""

from __future__ import annotations

import os
import types

import pytest
from click.testing import CliRunner

from esair_min.cli import main
from tests.support.board_lines import READY_BAD_T, READY_OK_T, VERSION_OK_T

URL = "esair://boards/papaman?speed=max"
VERSION = VERSION_OK_T


def send(*args: str):
    return CliRunner().invoke(main, ["send", *args])


def test_replies_in_order_and_exit_0():
    r = send(URL, "v", "t", "oab100", "s")
    assert r.exit_code == 0, r.output
    assert r.output.splitlines() == [VERSION, "OK", "OK", "OK 512,512,512,512,512,512,512,512"]


def test_error_reply_exits_1():
    r = send(URL, "zz", "v")
    assert r.exit_code == 1
    assert r.output.splitlines() == ["E01 unknown command", VERSION]


def test_notices_are_skipped_unless_asked():
    url = URL + "&scenario=push"
    r = send(url, "v", "--notices")
    assert r.output.splitlines() == [READY_OK_T, VERSION]
    r = send(url, "v")
    assert r.output.splitlines() == [VERSION]


def test_checksum_option():
    r = send(URL, "t", "PLY03", "--checksum")
    assert (r.exit_code, r.output) == (0, "OK\nOK\n")


def test_help_says_exit_1_on_error():
    r = send("--help")
    assert "exit 1 if any reply is an error" in " ".join(r.output.split())


def test_no_reply_times_out_on_a_silent_device():
    master, slave = os.openpty()          # a real tty device nobody answers on
    try:
        path = os.ttyname(slave)
        r = send(path, "v", "--timeout", "0.3")
        assert r.exit_code == 1
        assert r.output == "error: no reply to 'v' within 0.3 s\n"
    finally:
        os.close(master)
        os.close(slave)


def test_unopenable_port():
    r = send("/nonexistent/tty", "v")
    assert r.exit_code == 1
    assert r.output == ("error: cannot open /nonexistent/tty: [Errno 2] could not open port "
                        "/nonexistent/tty: [Errno 2] No such file or directory: "
                        "'/nonexistent/tty'\n")


def test_non_ascii_command():
    r = send(URL, "t\u00e9")
    assert (r.exit_code, r.output) == (1, "error: command 't\u00e9' is not ASCII\n")


@pytest.mark.parametrize("commands, message", [
    (["", "v"], "command '' is empty: the robot ignores empty lines and sends no reply; "
                "give one command per argument"),
    (["v", "t\rx"], "command 't\\rx' holds a line end; give each line as its own argument"),
    (["v", "t\u00e9"], "command 't\u00e9' is not ASCII"),
])
def test_a_bad_command_sends_nothing(commands, message):
    """Every command is checked before the first is sent: nothing reaches the robot."""
    from esair_min.cli.send import send_commands
    from esair_min.errors import EsairError

    class Port:
        written = b""

        def write(self, data):
            self.written += data

    port = Port()
    with pytest.raises(EsairError) as exc:
        send_commands(port, commands, 0.1, print)
    assert str(exc.value) == message
    assert port.written == b""
    r = send(URL, *commands)
    assert (r.exit_code, r.output) == (1, f"error: {message}\n")


# -- esair emulate: headless runs and option errors ----------------------------------------

def emulate(*args: str):
    return CliRunner().invoke(main, ["emulate", "boards/papaman", *args])


def test_headless_run_prints_the_output():
    r = emulate("--run", "0.5", "--send", "v", "--send", "DNC")
    assert r.exit_code == 0, r.output
    assert r.output.splitlines() == [READY_OK_T, VERSION, "OK"]


@pytest.mark.parametrize("args, message", [
    ((), "give --pty to serve the robot on a pseudo-terminal, or --run SECONDS to run it "
         "headless"),
    (("--pty", "--run", "1"), "--pty and --run exclude each other"),
    (("--pty", "--speed", "0"), "--speed 0 must be more than 0"),
    (("--pty", "--send", "v"), "--send works with --run only; with --pty, send lines from "
                               "another terminal: esair send PORT LINE..."),
    (("--run", "1", "--speed", "5"), "--speed works with --pty only; --run runs as fast as "
                                     "the host can"),
    (("--run", "-1"), "--run -1 must be 0 or more seconds"),
    (("--pty", "--hold-scenario"), "--hold-scenario needs --scenario: it holds that scenario "
                                   "until SIGUSR1"),
    (("--run", "1", "--scenario", "push", "--hold-scenario"),
     "--hold-scenario works with --pty only; with --run the scenario plays from boot"),
    (("--run", "1", "--noise", "-2"), "noise rate -2 must be 0 or more bytes per second"),
    (("--run", "1", "--trace", "/nonexistent/dir/t.txt"),
     "cannot write the trace /nonexistent/dir/t.txt: No such file or directory"),
    (("--run", "1", "--scenario", "pussh"),
     "no scenario 'pussh' (did you mean 'push'?): give a file, or one of the robot's "
     "scenarios (push, quiet)"),
])
def test_emulate_errors(args, message):
    r = emulate(*args)
    assert (r.exit_code, r.output) == (1, f"error: {message}\n")


def test_generate_then_emulate_the_generated_image(monkeypatch, tmp_path):
    """--generate calls esair_min.codegen.generate_robot(robot, DIR) first, then loads the EEPROM
    image it wrote: here a fake generator writes a corrupt image, and the robot says so."""
    from esair_min.core.image import build_image, write_hex

    calls = []

    def generate_robot(robot, out):
        calls.append((robot.name, out))
        (out / "central").mkdir(parents=True)
        data = bytearray(build_image(robot))
        data[20] ^= 0x01
        write_hex(bytes(data), out / "central" / "papaman-eeprom.hex")

    fake = types.ModuleType("codegen")
    fake.generate_robot = generate_robot
    monkeypatch.setattr("esair_min.codegen.generate_robot", fake.generate_robot)
    out = tmp_path / "build"
    r = emulate("--run", "0.2", "--generate", str(out), "--send", "PLY03")
    assert calls == [("papaman", out)]
    assert r.exit_code == 0
    assert r.stdout.splitlines() == [READY_BAD_T, "E09 motion image invalid"]


def test_generate_writes_the_image_when_the_generator_does_not(monkeypatch, tmp_path):
    from esair_min.core.image import build_image, read_hex
    from esair_min.resources import resolve_robot
    from esair_min.model.validate import load_robot

    fake = types.ModuleType("codegen")
    fake.generate_robot = lambda robot, out: (out / "central").mkdir(parents=True)
    monkeypatch.setattr("esair_min.codegen.generate_robot", fake.generate_robot)
    out = tmp_path / "build"
    r = emulate("--run", "0.2", "--generate", str(out), "--send", "PLY03")
    assert r.exit_code == 0
    assert r.stdout.splitlines() == [READY_OK_T, "OK"]
    robot = load_robot(resolve_robot("boards/papaman"))
    image = read_hex(out / "papaman-eeprom.hex", 32768)
    assert image[:len(build_image(robot))] == build_image(robot)
