"""The HMI's record button: the samples the HMI receives, written to MCAP by a thread of
their own (the caller only queues: bounded, what overflows is counted)."""

from __future__ import annotations

import queue
import threading
from pathlib import Path

from ..errors import StdError
from .mcapio import SampleWriter

QUEUE = 100_000


class Tap:
    def __init__(self, path: str | Path):
        self.path = Path(path)
        try:
            self.f = open(self.path, "wb")  # noqa: SIM115 - closed in stop()
        except OSError as exc:
            raise StdError(f"cannot write {self.path}: {exc.strerror}") from None
        self.writer = SampleWriter(self.f)
        self.q: queue.Queue = queue.Queue(QUEUE)
        self.c = dict(written=0, dropped=0)
        self._thread = threading.Thread(target=self._run, name="hmi:record", daemon=True)
        self._thread.start()

    def put(self, msg: dict) -> None:
        try:
            self.q.put_nowait(msg)
        except queue.Full:
            self.c["dropped"] += 1

    def _run(self) -> None:
        while True:
            m = self.q.get()
            if m is None:
                return
            self.writer.write(m["r"], int(m["q"]), float(m["ts"]), m["v"])
            self.c["written"] += 1

    def stop(self) -> None:
        self.q.put(None)
        self._thread.join()
        self.writer.finish()
        self.f.close()
