"""STARFISH's simulated radio never touches the machine's real network (issue 34 item 3):
a deployment naming the machine's own interface (a robot's wlan0 would cut the link to
it) is refused before anything starts, and the interface is as it was; in both modes.
The links it may switch are ESAIR's own (tests/net/test_netns.py)."""

import json
import subprocess
from pathlib import Path

import pytest

from esair_std import Runtime
from esair_std.errors import ComponentError
from tests.support.std import agent_children, free_endpoint

ROOM = str(Path(__file__).resolve().parents[2] / "esair_std/examples/starfish/room.yaml")


def _real_interface() -> str:
    """The machine's default route's interface, else its first one but loopback."""
    routes = json.loads(subprocess.run(["ip", "-j", "route", "show", "default"],
                                       capture_output=True, text=True, check=True).stdout)
    if routes:
        return routes[0]["dev"]
    names = sorted(p.name for p in Path("/sys/class/net").iterdir() if p.name != "lo")
    if not names:
        pytest.skip("this machine has no network interface but loopback")
    return names[0]


def _state(dev: str) -> tuple:
    link = json.loads(subprocess.run(["ip", "-j", "link", "show", "dev", dev],
                                     capture_output=True, text=True, check=True).stdout)[0]
    return link["flags"], link.get("operstate")


def test_the_machines_own_interface_is_refused_and_left_alone(mode):
    dev = _real_interface()
    before = _state(dev)
    dep = {"robot": "t", "resources": {"starfish": {
        "class": "esair_std.drivers.starfish:Starfish", "room_file": ROOM,
        "radio": {"device": dev}, "allow": {"*": "read"}}}}
    with pytest.raises(ComponentError) as exc, Runtime(dep, mode=mode, endpoint=free_endpoint()):
        pass
    assert str(exc.value) == (
        f"resource 'starfish' failed to open: StarfishError: starfish: radio.device {dev!r}: "
        "this process runs in the machine's own network namespace, not in one ESAIR made "
        "(esair-...); the simulated radio switches only a link ESAIR made for a simulation "
        "(esair_std/netsim.py): nothing was changed")
    assert _state(dev) == before
    assert agent_children() == []
