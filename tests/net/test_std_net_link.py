"""The link settings of every STD session (esair_std.transport.security_config.link_inserts)
across a real veth link: a partition drops the remote computer's session after the
lease (its liveliness token goes), the healed link brings it back by itself, and a
numbered stream shows exactly which samples the partition lost. Raw Zenoh sessions:
the runtime's own partition tests build on this."""

import time

from esair_std.transport.security_config import link_inserts
from tests.support.netns import wait_for
from bench.toolkit.zpeer import Peer

SENSOR, TOKEN = "esair/lab/sensor/s", "esair/lab/alive/sensor/s"


def _pair(net, lease_ms):
    ep = f"tcp/{net[0].addr}:7447"
    center = Peer(net[0], {"mode": "router", "scouting/multicast/enabled": False,
                           "listen/endpoints": [ep], **link_inserts(lease_ms)})
    center.cmd("alive esair/lab/alive/**")
    center.cmd(f"sub {SENSOR}")
    agent = Peer(net[1], {"mode": "client", "scouting/multicast/enabled": False,
                          "connect/endpoints": [ep], "listen/endpoints": [],
                          **link_inserts(lease_ms)})
    assert agent.error is None
    agent.cmd(f"token {TOKEN}")
    assert center.wait_event(lambda e: e.get("alive") == TOKEN, 60)
    return center, agent


def _events(center, kind):
    return [e for e in list(center.events) if kind in e]


def test_partition_drops_the_session_and_the_healed_link_brings_it_back(net):
    center, agent = _pair(net, lease_ms=800)
    agent.cmd(f"stream {SENSOR} 200 30")
    wait_for(lambda: len(center.samples(SENSOR)) > 50, what="the stream")
    net[1].link(up=False)
    assert center.wait_event(lambda e: e.get("gone") == TOKEN, 10), "token still alive"
    seen_at_drop = len(center.samples(SENSOR))
    time.sleep(1.0)                                   # the partition goes on
    assert len(center.samples(SENSOR)) == seen_at_drop    # nothing arrives meanwhile
    net[1].link(up=True)
    wait_for(lambda: len(_events(center, "alive")) == 2, timeout=10, what="the token back")
    wait_for(lambda: len(center.samples(SENSOR)) > seen_at_drop + 50, what="the stream back")
    seqs = [int(p) for p in center.samples(SENSOR)]
    gaps = [(a, b) for a, b in zip(seqs, seqs[1:]) if b != a + 1]
    assert len(gaps) == 1, gaps                # one hole: the partition, nothing else
    (last_before, first_after), = gaps
    assert first_after > last_before + 1       # exactly seqs last_before+1..first_after-1 lost
    assert seqs[0] == 1 and seqs == sorted(seqs)


def test_a_link_without_partition_loses_nothing(net):
    center, agent = _pair(net, lease_ms=2000)
    # its puts wait for a congested link as the runtime's streams do (bus.publisher): on a
    # busy computer zenoh's default (drop after 1 ms) loses samples the link never saw
    agent.cmd(f"stream {SENSOR} 1000 1 block")
    wait_for(lambda: center.samples(SENSOR)[-1:] == ["1000"], timeout=90, what="sample 1000")
    assert [int(p) for p in center.samples(SENSOR)] == list(range(1, 1001))
