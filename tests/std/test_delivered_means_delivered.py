""""Delivered" means delivered (issue 37 item 3), in both modes: a behavior's mailbox is
filled by four senders at once while its receive() is held; in process mode the BS puts
both kinds in it, deliveries into the room the behavior reserved for it (answered
"delivered" at once) and plain offers. Then the gate opens and what arrives is counted:
every put told delivered arrives exactly once, none told failed arrives, plain offers
never took the reserved room (no reserved delivery refused, the whole reserved room
used), and the mailbox never held more than its bounds."""

from __future__ import annotations

import threading

from esair_std.errors import ControlError
from esair_std.hosts.behavior_host import INBOX, RESERVED
from tests.support.std import wait_for

EACH = 40
BIG = "x" * 9000        # over modes/process.py's RESERVED_BYTES: always a plain offer
REFUSALS = 3            # refused in a row: a sender stops (the gate never opens meanwhile)


def test_a_full_mailbox_loses_no_delivered_put_and_keeps_its_bounds(start, mode, tmp_path):
    release = tmp_path / "release"
    rt = start({"behaviors": {"sink": {"class": "tests.support.comps:GatedSink",
                                       "release": str(release), "deadline": 120}}})
    told: dict[str, dict[int, bool]] = {s: {} for s in ("big0", "big1", "big2", "s0", "s1")}

    def send(sender: str, most: int = EACH, refusals: int = REFUSALS) -> None:
        """Up to ``most`` puts, until ``refusals`` in a row were refused: the mailbox is
        full for this sender's kind, and each refusal waits out its timeout."""
        row = 0
        for i in range(most):
            try:
                rt.put("sink", {"i": i, "pad": BIG if sender.startswith("big") else ""},
                       timeout=0.3, sender=sender)
                told[sender][i], row = True, 0
            except ControlError:
                told[sender][i], row = False, row + 1
                if row == refusals:
                    return
    # plain offers first, until the mailbox takes no more of them: they must leave the
    # reserved room free; then both kinds at once
    send("big0", most=10 * INBOX, refusals=1)
    threads = [threading.Thread(target=send, args=(s,)) for s in told if s != "big0"]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    delivered = {(s, i) for s, d in told.items() for i, ok in d.items() if ok}
    assert not all(ok for d in told.values() for ok in d.values()), "never filled"
    # the mailbox's bounds: what it holds, plus the one put receive() holds
    assert len(delivered) <= INBOX + RESERVED + 1
    counters = rt.inspect("sink")["counters"]
    release.touch()
    got = wait_for(lambda: (lambda g: g if len(g) >= len(delivered) else None)(
        rt.get("sink", timeout=5.0)["got"]), 60, what="every delivered put to arrive")
    arrived = [(s, d["i"]) for s, d in got]
    assert len(arrived) == len(set(arrived)), "a put arrived twice"
    assert set(arrived) == delivered
    after = rt.inspect("sink")["counters"]
    assert after["reserved_refused"] == 0
    small = {(s, i) for s, i in delivered if not s.startswith("big")}
    if mode == "process":       # the reserved room, all of it, for the BS's deliveries
        assert counters["reserved"] == len(small) >= RESERVED
        assert len(delivered) - len(small) >= INBOX
    else:                       # no reserved deliveries: offers alone, never in its room
        assert counters["reserved"] == 0 and INBOX <= len(delivered) <= INBOX + 1
