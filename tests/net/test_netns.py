"""The namespace helper itself: hosts reach each other only over their link, the link
goes down and up, and nothing is left behind (processes, namespaces, stale runs)."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.support import netns
from tests.support.netns import make_net

# Connect to HOST:PORT; print "ok" or the error's class name.
CONNECT = """
import socket, sys
try:
    socket.create_connection((sys.argv[1], int(sys.argv[2])), timeout=1.0).close()
    print("ok")
except OSError as exc:
    print(type(exc).__name__)
"""

SERVE = """
import socket
s = socket.socket(); s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
s.bind(("0.0.0.0", 7400)); s.listen(8); print("listening", flush=True)
while True:
    s.accept()[0].close()
"""


def _connect(host, addr, port=7400):
    return host.run(sys.executable, "-c", CONNECT, addr, str(port)).stdout.strip()


def _serve(host):
    proc = host.python("-c", SERVE, stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "listening"
    return proc


def test_two_hosts_reach_each_other_and_a_partition_cuts_them(net):
    a, b = net[0], net[1]
    assert (a.addr, b.addr) == ("10.77.0.1", "10.77.0.2")
    _serve(a)
    assert _connect(b, a.addr) == "ok"
    b.link(up=False)
    assert not b.link_is_up()
    assert _connect(b, a.addr) != "ok"
    b.link(up=True)
    netns.wait_for(lambda: _connect(b, a.addr) == "ok", timeout=10, what="the link back")


def test_addresses_exist_only_inside_the_namespaces(net):
    own = subprocess.run(["ip", "-br", "addr"], capture_output=True, text=True).stdout
    assert "10.77.0." not in own
    assert "10.77.0.1/24" in net[0].run("ip", "-br", "addr").stdout


def test_three_hosts_share_one_link(net3):
    _serve(net3[0])
    assert _connect(net3[1], net3[0].addr) == "ok"
    assert _connect(net3[2], net3[0].addr) == "ok"
    net3[2].link(up=False)
    assert _connect(net3[2], net3[0].addr) != "ok"
    assert _connect(net3[1], net3[0].addr) == "ok"


def test_close_kills_processes_and_deletes_namespaces():
    n = make_net(2)
    names = list(n.names)
    proc = n[1].python("-c", "import time; time.sleep(60)")
    stray = n[0].run("sh", "-c", "sleep 60 >/dev/null 2>&1 & echo $!").stdout.strip()
    n.close()
    assert proc.poll() is not None
    assert not os.path.exists(f"/proc/{stray}") or "Z" in Path(f"/proc/{stray}/stat").read_text().split()[2]
    assert not set(names) & set(netns.list_namespaces())
    n.close()                                   # idempotent


def test_close_runs_when_the_test_body_fails():
    with pytest.raises(ZeroDivisionError):
        with make_net(2) as n:
            names = list(n.names)
            raise ZeroDivisionError("the test body fails")
    assert not set(names) & set(netns.list_namespaces())


def test_stale_namespaces_of_dead_runs_are_removed():
    if netns.unavailable():
        pytest.skip(netns.unavailable())
    dead = subprocess.Popen(["true"])
    dead.wait()
    stale = f"esair-{dead.pid}-1-h0"
    subprocess.run(["ip", "netns", "add", stale], check=True)
    mine = make_net(2)
    try:
        assert stale not in netns.list_namespaces()
        assert set(mine.names) <= set(netns.list_namespaces())   # a live run is kept
        assert stale not in netns.clean_stale()
    finally:
        mine.close()


OWNED = ("import sys; from esair_std.netsim import owned_link_fault as f; "
         "print(f(sys.argv[1]))")


def test_only_the_link_esair_made_is_a_simulations_to_switch(net):
    """Its veth (alias esair-sim) in its namespace: yes; loopback there, or any device of
    the machine's own namespace: no, with the reason."""
    env = dict(os.environ, PYTHONPATH=str(netns.ROOT))
    host = net[0]
    assert host.run(sys.executable, "-c", OWNED, "eth1").stdout == "None\n"
    assert host.run(sys.executable, "-c", OWNED, "lo").stdout == (
        f"it is not a veth ESAIR made (alias 'esair-sim') in namespace {host.name}\n")
    assert host.run(sys.executable, "-c", OWNED, "wlan9").stdout == (
        f"no such link in namespace {host.name}\n")
    out = subprocess.run([sys.executable, "-c", OWNED, "eth1"], capture_output=True, text=True,
                         env=env, check=True).stdout
    assert out == ("this process runs in the machine's own network namespace, not in one "
                   "ESAIR made (esair-...)\n")
