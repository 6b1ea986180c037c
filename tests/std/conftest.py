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




def pytest_collection_modifyitems(items):
    """Tests named one by one (mutmut passes each mutant's tests as a set, in no order)
    run in their module's order: test_std_safety_rules puts the fast tests first, so a
    mutant they kill is not first run past the ones that start a robot. The modules keep
    the order they came in (tests/conftest.py's LONGEST_FIRST); in a normal run this
    changes nothing."""
    first: dict = {}
    for i, item in enumerate(items):
        first.setdefault(item.path, i)
    items.sort(key=lambda item: (first[item.path], item.reportinfo()[1] or 0))
