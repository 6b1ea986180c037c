"""``Replay``: a recording (MCAP, ``esair std record``) as sensors of a running robot.

    esair std replay run.mcap              # = esair std add-resource replay
                                           #   esair_std.record.replay:Replay -o file=...

Each channel of the file becomes a sensor ``<entry>.<topic>`` (``replay.papaman.feet``)
that reports the recorded values at their recorded pace (``speed``: 2 plays twice as
fast; ``loop: true`` starts again at the end), so behaviors and the HMI run against it.
"""

from __future__ import annotations

import threading
import time
from ..resource import Actuator, Driver, Sensor
from .mcapio import read_samples


class _Channel(Sensor):
    pass


class Replay(Driver):
    def open(self) -> None:
        path = self.options.get("file")
        speed = self.options.get("speed", 1.0)
        if not isinstance(path, str):
            raise ValueError("option 'file' (the MCAP recording) is missing")
        if isinstance(speed, bool) or not isinstance(speed, (int, float)) or speed <= 0:
            raise ValueError(f"option 'speed' must be a number above 0, got {speed!r}")
        self.samples = list(read_samples(path))
        if not self.samples:
            raise ValueError(f"{path} holds no samples")
        self.speed, self.loop = float(speed), bool(self.options.get("loop", False))
        self.kids = {topic: _Channel() for topic in dict.fromkeys(s[0] for s in self.samples)}
        self.played = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="replay", daemon=True)

    def resources(self) -> dict[str, Sensor | Actuator]:
        if not self._thread.is_alive():
            self._thread.start()
        return dict(self.kids)

    def _run(self) -> None:
        time.sleep(0.2)                       # the children are deployed before the first
        while not self._stop.is_set():
            t0, start = self.samples[0][2], time.monotonic()
            for topic, _seq, t, value in self.samples:
                if self._stop.wait(max(0.0, start + (t - t0) / self.speed - time.monotonic())):
                    return
                kid = self.kids[topic]
                if kid._esair is not None:
                    kid.report(value)
                    self.played += 1
            if not self.loop:
                return

    def close(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(2.0)
