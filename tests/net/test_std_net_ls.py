"""The control endpoint stays responsive while a remote link is cut (issue 37 item 5):
a control center and a remote behavior in two network namespaces; the link is cut, and
puts the sender waits for (``wait``) are sent to the remote behavior, more of them than
the control endpoint has workers, each holding one until its timeout. ``ls`` and
``ping``, sent after them on the same session, must be answered before any of those
puts: on an endpoint where they queue behind the puts, ``esair std ls`` went unanswered
("the runtime ... did not answer 'ls'"). Then the link heals and the remote behavior
comes back. Shown by the order of the answers, not by a time."""

from __future__ import annotations

import json
import subprocess
import sys

from esair_std.control.control_server import WORKERS
from tests.support.netns import wait_for
from bench.toolkit.netstd import Center, agent, env

LAB = """
robot: lab
mode: process
endpoint: ENDPOINT
security: {lease_ms: 1500}
resources:
  arm:   {class: "bench.toolkit.netcomps:Wheel", allow: {pusher: command}}
behaviors:
  idle:  {class: "bench.toolkit.netcomps:Idle"}
"""

PUTS = WORKERS + 2
PUT_TIMEOUT = 6.0

# every query is sent before the next (session.get returns once it is on its way), the
# puts before ls and ping; each answer is told as it arrives
ASKER = r"""
import json, sys, threading
from esair_std.transport.bus import Bus
bus = Bus(connect=[sys.argv[1]], options={"mode": "client", "listen/endpoints": []})
n, timeout = int(sys.argv[2]), float(sys.argv[3])
lock = threading.Lock()
def say(*what):
    with lock:
        print(json.dumps(what), flush=True)
assert bus.request("esair/lab/ctl/ping", {}, 10.0) is not None
say("ready")
sys.stdin.readline()
def ask(verb, body):
    return bus.session.get(f"esair/lab/ctl/{verb}", payload=json.dumps(body).encode(),
                           timeout=timeout + 10)
asked = [("put", ask("put", {"to": "pusher", "data": i, "timeout": timeout, "wait": True}))
         for i in range(n)]
asked += [("ls", ask("ls", {})), ("ping", ask("ping", {}))]
def wait(verb, replies):
    say(verb, any(r.ok is not None for r in replies))
ts = [threading.Thread(target=wait, args=a) for a in asked]
for t in ts:
    t.start()
for t in ts:
    t.join()
say("done")
"""


def test_ls_and_ping_answer_while_a_cut_remote_behavior_holds_every_worker(net, tmp_path):
    center = Center(net[0], tmp_path, LAB)
    agent(net[1], center.endpoint, "pusher", "bench.toolkit.netcomps:Pusher",
          "--uses", "arm=command")
    wait_for(lambda: center.state("pusher") == "running", 60, what="pusher running")
    asker = center.host.popen(sys.executable, "-c", ASKER, center.endpoint, str(PUTS),
                              str(PUT_TIMEOUT), stdin=subprocess.PIPE,
                              stdout=subprocess.PIPE, text=True, env=env())
    try:
        assert asker.stdin is not None and asker.stdout is not None
        assert json.loads(asker.stdout.readline()) == ["ready"]
        net[1].link(up=False)                                  # the cut
        center.run.wait_line("pusher: remote agent lost", 30)
        asker.stdin.write("go\n")
        asker.stdin.flush()
        answers = []
        for line in asker.stdout:
            answers.append(json.loads(line))
            if answers[-1] == ["done"]:
                break
    finally:
        net[1].link(up=True)                                   # healed
        if asker.poll() is None:
            asker.kill()
        asker.wait(10)
    verbs = [a[0] for a in answers[:-1]]
    assert sorted(verbs[:2]) == ["ls", "ping"], f"ls/ping answered after puts: {answers}"
    assert answers[:2] == [[v, True] for v in verbs[:2]], answers
    assert verbs[2:] == ["put"] * PUTS, answers
    wait_for(lambda: center.state("pusher") == "running", 60, what="pusher back")
