"""``esair std record``: watch sensors as the principal ``record`` (read, like the HMI)
and write their samples to MCAP, and every command the actuators run (their hosts
publish each one with its outcome: ``esair/<robot>/command/<actuator>``). Zenoh's
thread only queues a sample or a command (bounded; what overflows is counted); a writer
thread writes the file."""

from __future__ import annotations

import fnmatch
import queue
import threading
from typing import Any

from ..hmi.bridge import Bridge, BridgeError
from .mcapio import SampleWriter

QUEUE = 100_000


class Recorder:
    def __init__(self, endpoint: str, out: str, names: list[str] | None = None,
                 who: str = "record"):
        self.out, self.names = out, list(names or [])
        self.q: queue.Queue = queue.Queue(QUEUE)
        self.c = dict(written=0, dropped=0, gaps=0, commands=0, command_gaps=0)
        self._last: dict[str, int] = {}
        self._last_cmd: dict[str, int] = {}
        self.bridge = Bridge(endpoint, self._emit, who=who)
        self.bridge.want = self._wanted            # only the sensors asked for
        self._thread = threading.Thread(target=self._write, name="record:write", daemon=True)
        self.f: Any = None

    def _wanted(self, name: str) -> bool:
        return not self.names or any(fnmatch.fnmatchcase(name, p) for p in self.names)

    def _emit(self, msg: dict) -> None:
        if msg.get("t") != "s":
            return
        try:
            self.q.put_nowait(msg)
        except queue.Full:
            self.c["dropped"] += 1

    def start(self) -> None:
        try:
            self.f = open(self.out, "wb")  # noqa: SIM115 - closed in stop()
        except OSError as exc:
            raise BridgeError(f"cannot write {self.out}: {exc.strerror}") from None
        self.writer = SampleWriter(self.f)
        self._thread.start()
        try:
            self.bridge.start()
            assert self.bridge.bus is not None
            self.bridge.bus.subscribe(f"esair/{self.bridge.robot}/command/**", self._on_command,
                                      with_key=True)
        except BaseException:
            self.stop()
            raise

    def _on_command(self, key: str, obj: Any) -> None:
        res = key.rsplit("/command/", 1)[-1]
        if not isinstance(obj, dict) or not self._wanted(res):
            return
        try:
            self.q.put_nowait({"t": "c", "r": res, "m": obj})
        except queue.Full:
            self.c["dropped"] += 1

    def _write(self) -> None:
        while True:
            m = self.q.get()
            if m is None:
                return
            if m["t"] == "c":
                self._write_command(m["r"], m["m"])
                continue
            res, seq = m["r"], int(m["q"])
            last = self._last.get(res)
            if last is not None and seq != last + 1:
                self.c["gaps"] += 1
            self._last[res] = seq
            self.writer.write(res, seq, float(m["ts"]), m["v"])
            self.c["written"] += 1

    def _write_command(self, res: str, rec: dict) -> None:
        try:
            seq, t, v = int(rec["seq"]), float(rec["t"]), dict(rec["v"])
        except (KeyError, TypeError, ValueError):
            self.c["dropped"] += 1                  # not a command record
            return
        last = self._last_cmd.get(res)
        if last is not None and seq != last + 1:
            self.c["command_gaps"] += 1
        self._last_cmd[res] = seq
        self.writer.write_command(res, seq, t, v)
        self.c["commands"] += 1

    def stop(self) -> dict:
        self.bridge.close()
        self.q.put(None)
        if self._thread.is_alive():
            self._thread.join()
        self.writer.finish()
        self.f.close()
        return dict(self.c, channels=len(self.writer.channels))
