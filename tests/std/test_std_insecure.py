"""An address other computers reach, without security, is refused by `esair std run`,
`agent` and `hmi` alike, or taken with an explicit --insecure that warns (issue 34
item 3): nothing listens on every interface by accident. With --insecure they serve, and
warn: tests/net/test_std_insecure_net.py (an address of a network namespace, not of this
machine)."""

import socket

import pytest

from tests.support.std import MODES, esair, free_endpoint

RUN_NEEDS = ("needs TLS client certificates (a tls/ endpoint) or logins: a security section "
             "(docs/std-network.md), or --insecure to go without")


def _any_port() -> int:
    return int(free_endpoint().rsplit(":", 1)[1])


@pytest.mark.parametrize("mode", MODES)
def test_run_on_every_interface_without_security_is_refused(mode, tmp_path):
    port = _any_port()
    # the port held here: a run that tried to listen before refusing would say "port in
    # use" (whether nothing listens afterwards proves nothing: another test may take it)
    with socket.create_server(("0.0.0.0", port)):
        r = esair("run", "lab", "--mode", mode, "-e", f"tcp/0.0.0.0:{port}", "--run", "0",
                  check=False)
        assert (r.returncode, r.stderr) == (
            1, f"error: listening on tcp/0.0.0.0:{port} reaches other computers: it "
               f"{RUN_NEEDS}\n")
        # the file's endpoint likewise (here a host name: not loopback)
        dep = tmp_path / "robot.yaml"
        dep.write_text(f"robot: t\nmode: {mode}\nendpoint: tcp/robot.example:{port}\n"
                       "behaviors:\n  b: {class: 'tests.support.comps:Faulty'}\n")
        r = esair("run", str(dep), "--run", "0", check=False)
        assert (r.returncode, r.stderr) == (
            1, f"error: listening on tcp/robot.example:{port} reaches other computers: it "
               f"{RUN_NEEDS}\n")
    # loopback needs nothing
    r = esair("run", "lab", "--mode", mode, "-e", f"tcp/127.0.0.1:{port}", "--run", "0")
    assert "warning" not in r.stderr


def test_agent_to_another_computer_without_security_is_refused():
    args = ("agent", "--connect", "tcp/192.0.2.7:7447", "pen", "esair_std.drivers.sim:Recorder",
            "--allow", "*=command")
    r = esair(*args, check=False)
    assert (r.returncode, r.stderr) == (
        1, "error: connecting to tcp/192.0.2.7:7447 reaches other computers: it needs TLS (a "
           "tls/ endpoint, --ca and --cert) or a login (--user, --password-file), or "
           "--insecure to go without\n")
    # with --insecure: the warning, then it tries (nobody answers at that test address)
    r = esair(*args, "--insecure", check=False)
    assert r.stderr.splitlines()[0] == (
        "warning: connecting to tcp/192.0.2.7:7447 without security (--insecure): anyone on "
        "the network can reach the robot"), r.stderr
