"""Network namespaces ESAIR makes for simulations: the many-computer tests, the
benches, and the only links STARFISH's radio model may set down and up (linkswitch.py).

``Net(2)`` makes two namespaces joined by one veth pair (``eth1`` in each, 10.77.0.1/24
and 10.77.0.2/24); ``Net(3)`` or more joins them through a bridge in a third "switch"
namespace, host ``i`` at 10.77.0.(i+1)/24. The addresses exist only inside these
namespaces: nothing is routed to or from the machine's own network. Every process started
with :meth:`Host.popen` runs inside its host (``ip netns exec``), in its own session.

:meth:`Net.close` (also on ``with`` exit, at interpreter exit and from the pytest fixture
``net`` of tests/support/netns.py, whether the test passed, failed or was interrupted) kills every process
left in the namespaces and deletes them. A run killed outright leaves its namespaces
behind; the next ``Net`` removes every ``esair-<pid>-...`` namespace whose ``pid`` is no
longer alive (``clean_stale``). Names are unique per run: ``esair-<pid>-<n>-<host>``.

Each host's link is a veth whose alias is :data:`ALIAS`: with the namespace's name
(``esair-...``), what :func:`owned_link_fault` asks of a link before a simulation may
switch it. Root (or CAP_SYS_ADMIN + CAP_NET_ADMIN) and iproute2 are needed;
:func:`unavailable` says why namespaces cannot be made here (the fixture then skips
with that reason).
"""

from __future__ import annotations

import atexit
import itertools
import os
import re
import shutil
import signal
import subprocess
import sys
import time

PREFIX = "esair-"
SUBNET = "10.77.0"
DEV = "eth1"
#: the alias of every link ESAIR makes here (``ip link ... alias``)
ALIAS = "esair-sim"
_counter = itertools.count(1)
_open: list[Net] = []
_NAME = re.compile(rf"^{PREFIX}(\d+)-\d+-\w+$")


class NetnsError(RuntimeError):
    """An ``ip`` command failed."""


def _ip(*args: str, check: bool = True) -> subprocess.CompletedProcess:
    proc = subprocess.run(["ip", *args], capture_output=True, text=True, timeout=20)
    if check and proc.returncode:
        raise NetnsError(f"ip {' '.join(args)}: {proc.stderr.strip() or proc.returncode}")
    return proc


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def list_namespaces() -> list[str]:
    out = _ip("netns", "list", check=False).stdout
    return [line.split()[0] for line in out.splitlines() if line.strip()]


def _kill_and_delete(name: str) -> None:
    pids = _ip("netns", "pids", name, check=False).stdout.split()
    for pid in pids:
        try:
            os.kill(int(pid), signal.SIGKILL)
        except (ProcessLookupError, ValueError):
            pass
    for pid in pids:                       # reap what is ours, wait for the rest
        _wait_gone(int(pid))
    proc = _ip("netns", "delete", name, check=False)
    if proc.returncode:
        print("NETNS DELETE", name, proc.stderr, file=sys.stderr)


def _wait_gone(pid: int, timeout: float = 5.0) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        try:
            if os.waitpid(pid, os.WNOHANG)[0]:
                return
        except ChildProcessError:
            if not _pid_alive(pid):
                return
        time.sleep(0.01)


def clean_stale() -> list[str]:
    """Delete the namespaces of ESAIR runs whose process is gone; returns their names."""
    gone = []
    for name in list_namespaces():
        m = _NAME.match(name)
        if m and not _pid_alive(int(m.group(1))):
            _kill_and_delete(name)
            gone.append(name)
    return gone


def unavailable() -> str | None:
    """Why network namespaces cannot be made on this machine, or None if they can."""
    if sys.platform != "linux":
        return f"network namespaces need Linux (this is {sys.platform})"
    if shutil.which("ip") is None:
        return "iproute2's `ip` is not installed (scripts/install-toolchain.sh installs it)"
    probe = f"{PREFIX}{os.getpid()}-0-probe"
    proc = _ip("netns", "add", probe, check=False)
    if proc.returncode:
        return f"cannot create a network namespace: {proc.stderr.strip()} (root is needed)"
    _ip("netns", "delete", probe, check=False)
    return None


class Host:
    """One namespace: a computer with address ``addr`` on the shared link."""

    def __init__(self, net: Net, name: str, addr: str):
        self.net, self.name, self.addr = net, name, addr
        self.procs: list[subprocess.Popen] = []

    def __repr__(self) -> str:
        return f"Host({self.name}, {self.addr})"

    def run(self, *cmd: str, check: bool = True, timeout: float = 30) -> subprocess.CompletedProcess:
        """Run ``cmd`` in this namespace to completion (text output captured)."""
        proc = subprocess.run(["ip", "netns", "exec", self.name, *cmd],
                              capture_output=True, text=True, timeout=timeout)
        if check and proc.returncode:
            raise NetnsError(f"{self.name}: {' '.join(cmd)} exited {proc.returncode}: "
                             f"{proc.stderr.strip()}")
        return proc

    def popen(self, *cmd: str, **kw) -> subprocess.Popen:
        """Start ``cmd`` in this namespace in its own session; killed by Net.close()."""
        kw.setdefault("start_new_session", True)
        proc = subprocess.Popen(["ip", "netns", "exec", self.name, *cmd], **kw)
        self.procs.append(proc)
        return proc

    def python(self, *args: str, **kw) -> subprocess.Popen:
        """``popen`` of this interpreter (same venv) with ``args``."""
        return self.popen(sys.executable, *args, **kw)

    def link(self, up: bool) -> None:
        """Take this host's link down (a partition) or bring it up again."""
        _ip("-n", self.name, "link", "set", DEV, "up" if up else "down")

    def link_is_up(self) -> bool:
        return "state UP" in _ip("-n", self.name, "link", "show", DEV).stdout


class Net:
    """``n`` hosts on one link; use as a context manager or call close()."""

    def __init__(self, n: int = 2):
        if n < 2:
            raise ValueError("a network needs at least 2 hosts")
        clean_stale()
        run = f"{PREFIX}{os.getpid()}-{next(_counter)}"
        self.names: list[str] = []
        self.hosts: list[Host] = []
        _open.append(self)
        try:
            self._build(run, n)
        except BaseException:
            self.close()
            raise

    def _add_ns(self, name: str) -> str:
        _ip("netns", "add", name)
        self.names.append(name)
        _ip("-n", name, "link", "set", "lo", "up")
        return name

    def _build(self, run: str, n: int) -> None:
        names = [self._add_ns(f"{run}-h{i}") for i in range(n)]
        if n == 2:
            _ip("link", "add", "name", DEV, "netns", names[0], "type", "veth",
                "peer", "name", DEV, "netns", names[1])
        else:
            sw = self._add_ns(f"{run}-sw")
            _ip("-n", sw, "link", "add", "br0", "type", "bridge")
            _ip("-n", sw, "link", "set", "br0", "up")
            for i, name in enumerate(names):
                port = f"p{i}"
                _ip("link", "add", "name", DEV, "netns", name, "type", "veth",
                    "peer", "name", port, "netns", sw)
                _ip("-n", sw, "link", "set", port, "master", "br0")
                _ip("-n", sw, "link", "set", port, "up")
        for i, name in enumerate(names):
            addr = f"{SUBNET}.{i + 1}"
            _ip("-n", name, "link", "set", DEV, "alias", ALIAS)
            _ip("-n", name, "addr", "add", f"{addr}/24", "dev", DEV)
            _ip("-n", name, "link", "set", DEV, "up")
            self.hosts.append(Host(self, name, addr))

    def __getitem__(self, i: int) -> Host:
        return self.hosts[i]

    def __enter__(self) -> Net:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Stop every process left in the namespaces and delete them (idempotent)."""
        for host in self.hosts:
            for proc in host.procs:
                if proc.poll() is None:
                    try:
                        os.killpg(proc.pid, signal.SIGKILL)
                    except ProcessLookupError:
                        pass
                try:
                    proc.wait(timeout=5)
                except subprocess.TimeoutExpired:
                    pass
        for name in reversed(self.names):
            _kill_and_delete(name)
        self.names.clear()
        if self in _open:
            _open.remove(self)


@atexit.register
def _close_all() -> None:
    for net in list(_open):
        net.close()


def wait_for(pred, timeout: float = 10.0, interval: float = 0.02, what: str = "condition"):
    """Poll ``pred`` until it returns a true value (returned) or fail after ``timeout``."""
    end = time.monotonic() + timeout
    while True:
        value = pred()
        if value:
            return value
        if time.monotonic() > end:
            raise AssertionError(f"timed out after {timeout} s waiting for {what}")
        time.sleep(interval)




def namespace_of_this_process() -> str | None:
    """The name of the named network namespace (``ip netns``) this process runs in, or
    None (the machine's own, or one nobody named)."""
    try:
        mine = os.stat("/proc/self/ns/net")
    except OSError:
        return None
    for name in list_namespaces():
        try:
            st = os.stat(f"/run/netns/{name}")
        except OSError:
            continue
        if (st.st_ino, st.st_dev) == (mine.st_ino, mine.st_dev):
            return name
    return None


def owned_link_fault(device: str) -> str | None:
    """None when ``device`` is a link ESAIR made for a simulation (a veth with the alias
    :data:`ALIAS`) in a network namespace ESAIR made (``esair-...``) that this process
    runs in; else why a simulation must not touch it."""
    ns = namespace_of_this_process()
    if ns is None or not ns.startswith(PREFIX):
        return ("this process runs in the machine's own network namespace, not in one ESAIR "
                "made (esair-...)")
    proc = _ip("-d", "-j", "link", "show", "dev", device, check=False)
    if proc.returncode:
        return f"no such link in namespace {ns}"
    import json
    try:
        link = json.loads(proc.stdout)[0]
    except (ValueError, IndexError):
        return f"`ip link show {device}` said nothing readable"
    kind = (link.get("linkinfo") or {}).get("info_kind")
    if kind != "veth" or link.get("ifalias") != ALIAS:
        return f"it is not a veth ESAIR made (alias {ALIAS!r}) in namespace {ns}"
    return None
