"""STD fixtures: every rule runs in both modes (the ``mode`` fixture)."""

import pytest

from esair_std import Runtime
from tests.support.std import MODES, agent_children, free_endpoint


@pytest.fixture(params=MODES)
def mode(request):
    return request.param


@pytest.fixture
def start(mode):
    """start(deployment_dict) -> a started Runtime in this test's mode; stopped after."""
    started = []

    def _start(dep, **kw):
        dep = dict(dep)
        dep.setdefault("robot", "t")
        rt = Runtime(dep, mode=mode, endpoint=free_endpoint(), **kw)
        rt.start()
        started.append(rt)
        return rt

    yield _start
    for rt in started:
        rt.stop()
    assert agent_children() == [], "agent processes left behind"


