"""`--insecure` (issue 34 item 3): the control center, the HMI and an agent on addresses
other computers reach, without security, start when asked to, each with its warning,
and serve: the other computer of two network namespaces reaches them (the machine's own
interfaces are never listened on)."""

from __future__ import annotations

import sys

from tests.support.netns import wait_for
from bench.toolkit.netstd import Center, Proc, agent, cli

LAB = """
robot: lab
mode: process
endpoint: ENDPOINT
behaviors:
  idle:  {class: "bench.toolkit.netcomps:Idle"}
"""

WARNING = "without security (--insecure): anyone on the network can reach the robot"

FETCH = ("import sys, urllib.request; "
         "print(urllib.request.urlopen(sys.argv[1], timeout=30).status)")


def test_run_hmi_and_agent_with_insecure_warn_and_serve(net, tmp_path):
    center = Center(net[0], tmp_path, LAB)             # run ... --insecure (netstd)
    assert f"warning: listening on {center.endpoint} {WARNING}" in center.run.lines
    hmi = Proc(net[0], cli("hmi", "-e", center.endpoint, "--listen", f"{net[0].addr}:0",
                           "--insecure"))
    url = hmi.wait_line("http://", 60).strip()
    assert url.startswith(f"http://{net[0].addr}:")
    assert net[1].run(sys.executable, "-c", FETCH, url).stdout == "200\n"
    assert f"warning: listening on {net[0].addr} {WARNING}" in hmi.lines
    spare = agent(net[1], center.endpoint, "spare", "bench.toolkit.netcomps:Idle")
    spare.wait_line("agent 'spare' joined robot 'lab'", 60)
    assert spare.lines[0] == f"warning: connecting to {center.endpoint} {WARNING}"
    wait_for(lambda: center.state("spare") == "running", 30, what="the remote agent")
