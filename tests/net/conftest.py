"""Fixtures of the network tests: hosts as network namespaces (tests/support/netns.py)."""

import pytest

from tests.support.netns import make_net


@pytest.fixture
def net():
    """Two hosts joined by a veth pair; removed after the test whatever its outcome."""
    with make_net(2) as n:
        yield n


@pytest.fixture
def net3():
    """Three hosts on one bridged link (two control centers and a remote agent)."""
    with make_net(3) as n:
        yield n
