"""The radio model acting on a network link ESAIR made for a simulation: ``ip link set
DEV up|down`` whenever the modelled radio is cut or heals (the namespace tests: the
robot's end of the veth to the remote control center).

Only such a link: a veth ESAIR made (its alias ``esair-sim``) in a network namespace ESAIR
made (``esair-...``, esair_std/netsim.py) that this process runs in. Any other device (a
robot's real ``wlan0``, which would cut the link to the robot) is refused before anything
is switched (:func:`esair_std.netsim.owned_link_fault`).

Changes are handed to one worker thread through a one-slot mailbox (only the newest
wanted state matters), so the sensor that noticed the change never waits for ``ip``. A
failed ``ip`` is counted (``failures``) and its message kept (``last_error``); the next
change tries again.
"""

from __future__ import annotations

import subprocess
import threading
from typing import Callable

from ...netsim import owned_link_fault


class LinkSwitch:
    def __init__(self, device: str, command: tuple[str, ...] = ("ip", "link", "set"),
                 owned: Callable[[str], str | None] = owned_link_fault):
        if not device or not all(c.isalnum() or c in "-_.@" for c in device):
            raise ValueError(f"radio.device must be a network interface name, not {device!r}")
        fault = owned(device)
        if fault is not None:
            raise ValueError(f"radio.device {device!r}: {fault}; the simulated radio switches "
                             "only a link ESAIR made for a simulation (esair_std/netsim.py): "
                             "nothing was changed")
        self.device, self.command = device, command
        self.wanted: bool | None = None
        self.applied: bool | None = None
        self.switches = self.failures = 0
        self.last_error = ""
        self._cv = threading.Condition()
        self._closed = False
        self._thread = threading.Thread(target=self._run, name=f"radio-link:{device}", daemon=True)
        self._thread.start()

    def set(self, up: bool) -> None:
        with self._cv:
            if self.wanted != up:
                self.wanted = up
                self._cv.notify()

    def close(self) -> None:
        with self._cv:
            self._closed = True
            self._cv.notify()
        self._thread.join(timeout=10)

    def _run(self) -> None:
        while True:
            with self._cv:
                self._cv.wait_for(lambda: self._closed or self.wanted != self.applied)
                if self._closed:
                    return
                want = self.wanted
            proc = subprocess.run([*self.command, self.device, "up" if want else "down"],
                                  capture_output=True, text=True, timeout=20)
            with self._cv:
                if proc.returncode:
                    self.failures += 1
                    self.last_error = proc.stderr.strip() or f"exit status {proc.returncode}"
                    self.applied = None if self.wanted == want else self.applied
                    if self.wanted == want:
                        self._cv.wait(0.5)           # a short pause before trying again
                else:
                    self.applied = want
                    self.switches += 1
