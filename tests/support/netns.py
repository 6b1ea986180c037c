"""The network namespaces of the many-computer tests (esair_std/netsim.py, which makes
them) and their pytest fixtures: ``net`` (two hosts joined by a veth) and ``net3``
(three hosts on a bridge); each skips with the reason when namespaces cannot be made."""

from __future__ import annotations

from pathlib import Path

import pytest

from esair_std.netsim import (ALIAS, DEV, PREFIX, SUBNET, Host, Net, NetnsError,  # noqa: F401
                              clean_stale, list_namespaces, owned_link_fault, unavailable,
                              wait_for)


def make_net(n: int = 2) -> Net:
    """A Net, or a pytest skip naming why namespaces cannot be made here."""
    why = unavailable()
    if why:
        pytest.skip(why)
    return Net(n)


ROOT = Path(__file__).resolve().parents[2]
