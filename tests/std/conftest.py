"""STD fixtures: every rule runs in both modes (the ``mode`` fixture)."""

import pytest

from esair_std import Runtime
from tests.support.std import MODES, agent_children, free_endpoint


@pytest.fixture(params=MODES)
def mode(request):
    return request.param


@pytest.fixture
def start(mode):
    """start(deployment_dict or file) -> a started Runtime in this test's mode; stopped
    after."""
    started = []

    def _start(dep, **kw):
        if isinstance(dep, dict):
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




#: The safety-rule modules (the tests scripts/mutation_std.sh runs), fast ones first.
SAFETY_RULES = ("test_supervisor_rules.py", "test_connections_rules.py",
                "test_resource_host_rules.py", "test_resource_host_runtime.py")


def pytest_collection_modifyitems(items):
    """The safety-rule tests named one by one (mutmut passes each mutant's tests as a
    set, in no order) run in these modules' order, each module's in its own: the fast
    tests first, so a mutant they kill is not first run past the ones that start a
    robot. Every other item keeps its place (pytest groups module-scoped parametrized
    fixtures); in a normal run this changes nothing."""
    mine = [item for item in items if item.path.name in SAFETY_RULES]
    if mine:
        at = items.index(mine[0])
        rest = [item for item in items if item.path.name not in SAFETY_RULES]
        mine.sort(key=lambda item: (SAFETY_RULES.index(item.path.name),
                                    item.reportinfo()[1] or 0))
        items[:] = rest[:at] + mine + rest[at:]
