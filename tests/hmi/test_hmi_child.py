"""`esair std run --hmi`'s child: an HMI that cannot start is said with its own words."""

from __future__ import annotations

import pytest

from esair_std.errors import StdError
from esair_std.hmi.child import HmiChild
from tests.support.hmi import free_port


def test_an_hmi_that_cannot_start_says_why():
    ep = f"tcp/127.0.0.1:{free_port()}"             # nobody answers there
    child = HmiChild(ep, "127.0.0.1:0")
    with pytest.raises(StdError) as err:
        child.start()
    assert str(err.value) == (f"the HMI did not start: error: no ESAIR STD runtime answers on "
                              f"{ep} (is `esair std run` running?)")
    assert child.proc is None                       # ended, nothing left running
