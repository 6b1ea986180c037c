"""``esair std record``: watch sensors as the principal ``record`` (read, like the HMI)
and write their samples to MCAP, and every command the actuators run (their hosts
publish each one with its outcome, in batches: ``esair/<robot>/commands/<entry>``). The file is
written by a :class:`~.tap.Tap`, as the HMI's record button writes it."""

from __future__ import annotations

import fnmatch

from ..hmi.bridge import Bridge
from ..transport.codec import JSONObject
from .tap import Tap


class Recorder:
    def __init__(self, endpoint: str, out: str, names: list[str] | None = None,
                 who: str = "record"):
        self.out, self.names = out, list(names or [])
        self.tap: Tap | None = None
        self.bridge = Bridge(endpoint, self._emit, who=who)
        self.bridge.want = self._wanted            # only the sensors asked for

    def _wanted(self, name: str) -> bool:
        return not self.names or any(fnmatch.fnmatchcase(name, p) for p in self.names)

    def _emit(self, msg: JSONObject) -> None:
        tap = self.tap
        if tap is not None:
            tap.put(msg)

    def start(self) -> None:
        self.tap = Tap(self.out, self._wanted)      # StdError: cannot write OUT
        try:
            self.bridge.start()
            assert self.bridge.bus is not None
            self.tap.listen(self.bridge.bus, self.bridge.robot)
            if self.bridge.latch.get("stopped"):   # STOPPED from its start: said first
                self.tap.put({"t": "latch", "v": self.bridge.latch})
        except BaseException:
            self.stop()
            raise

    def stop(self) -> dict[str, int]:
        tap, self.tap = self.tap, None
        c = tap.stop() if tap is not None else {}
        self.bridge.close()
        return c
