"""Runtime counters that several threads change (a host's transport threads, its
worker, a link's I/O thread and its callers) lose no count: every update goes through
esair_std.counters.Counters.add (one lock) or is made under the owner's lock.

The hammer tests switch threads every microsecond (sys.setswitchinterval) so that an
update made of a read and a write apart is split as often as it can be: the form
``c[k] = c.get(k, 0) + 1`` (host.py's refused puts before) lost 45 % of 400 000
counts that way; on CPython 3.11 ``c[k] += 1`` on a dict is not split by the GIL today
(no call between its read and its write), which the language does not promise
(free-threaded builds): the source check below keeps every such update on a lock."""

from __future__ import annotations

import ast
import sys
import threading
from pathlib import Path

import pytest

from esair_std import Actuator
from esair_std.counters import Counters
from esair_std.hosts.resource_host import COMMANDS, ResourceHost
from esair_std.spec import Spec
from tests.support.std import ROOT, wait_for

THREADS = 8


@pytest.fixture
def switchy():
    """Threads switch every microsecond while the test runs."""
    old = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    yield
    sys.setswitchinterval(old)


def hammer(fn, n: int) -> None:
    """``fn()`` n times in each of THREADS threads, all let go at once."""
    go = threading.Barrier(THREADS)

    def run() -> None:
        go.wait()
        for _ in range(n):
            fn()
    threads = [threading.Thread(target=run) for _ in range(THREADS)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()


def test_counters_hammered_from_threads_keep_every_count(switchy):
    c = Counters(a=0)
    keys = ("a", "b", "c")
    turn = iter(range(10**9))
    hammer(lambda: c.add(keys[next(turn) % 3]), 30_000)
    assert sum(c.values()) == THREADS * 30_000
    assert c.snapshot() == dict(c) == {"a": 80_000, "b": 80_000, "c": 80_000}
    c.add("a", 5)
    c["copied"] = 7
    assert (c["a"], c["copied"], c["never"], "never" in c, "a" in c) == (80_005, 7, 0, False, True)
    assert c == {"a": 80_005, "b": 80_000, "c": 80_000, "copied": 7}


class Gate(Actuator):
    """write() waits for one release of ``options["gate"]``."""

    def write(self, command):
        assert self.options["gate"].acquire(timeout=30.0)
        return command


class Port:
    def publish(self, resource, sample):
        pass

    def publish_commands(self, entry, batch):
        pass

    def resource_state_changed(self, resource, state, reason):
        pass


def test_a_full_command_queue_counts_every_refusal_from_many_threads(switchy):
    """Senders on 8 threads at once fill the host's bounded command queue (write() held):
    each command refused "command queue full" is counted once in commands_refused."""
    gate = threading.Semaphore(0)
    host = ResourceHost(Spec("resource", "arm", f"{__name__}:Gate", {"gate": gate}), Gate, Port())
    assert host.start() == {"arm": "actuator"}
    answers: list[tuple[bool, object]] = []
    try:
        hammer(lambda: host.submit("arm", "write", ("x",), lambda ok, v: answers.append((ok, v)),
                                   timeout=30.0), 500)
        refused = [a for a in answers if a == (False, "command queue full")]
        assert len(refused) >= THREADS * 500 - COMMANDS - 1       # the queue and write()
        assert host.counters()["commands_refused"] == len(refused)
    finally:
        gate.release(THREADS * 500)
        wait_for(lambda: len(answers) == THREADS * 500, what="every command answered")
        host.stop()
    assert host.counters()["arm"]["commands"] == THREADS * 500 - len(refused)


def _unlocked_updates(path: Path) -> list[str]:
    """Read-modify-writes of a counter outside a ``with ..lock:`` block: ``X.c[k] += n``
    or ``X.stats[k] = X.stats.get(k, 0) + n`` (``c``, ``stats``: the counters' names)."""
    tree = ast.parse(path.read_text())
    found: list[str] = []

    def counter(target: ast.expr) -> bool:
        return (isinstance(target, ast.Subscript) and isinstance(target.value, ast.Attribute)
                and target.value.attr in ("c", "stats"))

    def visit(node: ast.AST, locked: bool) -> None:
        if isinstance(node, ast.With) and any(
                "lock" in ast.unparse(item.context_expr).lower() for item in node.items):
            locked = True
        targets = ([node.target] if isinstance(node, ast.AugAssign) else
                   [t for t in node.targets if isinstance(t, ast.Subscript)
                    and ast.unparse(t.value) in ast.unparse(node.value)]
                   if isinstance(node, ast.Assign) else [])
        if not locked and any(counter(t) for t in targets):
            found.append(f"{path.relative_to(ROOT)}:{node.lineno}: {ast.unparse(node)}")
        for child in ast.iter_child_nodes(node):
            visit(child, locked)
    visit(tree, False)
    return found


def test_every_counter_update_in_esair_std_is_atomic():
    files = sorted((ROOT / "esair_std").rglob("*.py"))
    assert any("hmi" in p.parts for p in files)         # the HMI's counters too
    assert len(files) > 50
    assert [f for p in files for f in _unlocked_updates(p)] == []


def test_every_count_of_the_hmi_is_a_counter():
    """The HMI's counts (a page's dropped frames, the failed logins...) are Counters,
    which /status.json shows: no ``x.name += n`` on a plain attribute in esair_std/hmi,
    nor in the bus it asks through (its foreign answers)."""
    found = []
    for path in [*sorted((ROOT / "esair_std" / "hmi").rglob("*.py")),
                 ROOT / "esair_std" / "transport" / "bus.py"]:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.AugAssign) and isinstance(node.target, ast.Attribute):
                found.append(f"{path.relative_to(ROOT)}:{node.lineno}: {ast.unparse(node)}")
    assert found == []
