"""A recording being written: what ``esair std record`` and the HMI's record button share.

:class:`Tap` takes the samples a :class:`~esair_std.hmi.bridge.Bridge` emits (``{"t":
"s", ...}``) and the command records the actuators' hosts publish (``esair/<robot>/
command/<actuator>``: ``{seq, t, v: {command, ok | error}}``, subscribed with
:meth:`Tap.listen`), and the latched STOP's state (``{"t": "latch"}``, channel ``latch``), and writes them
to MCAP on a thread of its own, with the log lines, behaviors' states and link
state it emits (Foxglove's channels: foxmsgs.py): the callers (Zenoh's
thread, the bridge) only queue (bounded; what overflows is counted in ``dropped``). A
sample or command number that does not follow the last one of its resource is a gap,
counted too."""

from __future__ import annotations

import functools
import queue
import threading
import time
from pathlib import Path
from typing import TYPE_CHECKING, Callable, cast

from ..errors import StdError
from ..transport import keys, records
from .mcapio import SampleWriter
from ..counters import Counters
from ..transport.codec import JSON, JSONObject

if TYPE_CHECKING:  # pragma: no cover
    from ..transport.bus import Bus

QUEUE = 100_000
LINGER_S = records.BATCH_S + 0.1     # stop(): the last records in flight (their batch, the link)


class Tap:
    def __init__(self, path: str | Path, wanted: Callable[[str], bool] | None = None):
        self.path = Path(path)
        self.wanted = wanted or (lambda _name: True)
        try:
            self.f = open(self.path, "wb")  # noqa: SIM115 - closed in stop()
        except OSError as exc:
            raise StdError(f"cannot write {self.path}: {exc.strerror}") from None
        self.writer = SampleWriter(self.f)
        # what the writer thread gets (None: stop), tagged by "t": s sample, l latch,
        # m message, c command record
        self.q: queue.Queue[JSONObject | None] = queue.Queue(QUEUE)
        self.c = Counters(written=0, dropped=0, gaps=0, commands=0, command_gaps=0)
        self._last: dict[str, int] = {}
        self._last_cmd: dict[str, int] = {}
        self._latches = 0
        self._subs: list[Callable[[], None]] = []    # each undoes a subscription
        self._thread = threading.Thread(target=self._run, name="record:write", daemon=True)
        self._thread.start()

    # ---- what the callers hand over (any thread: queue only)
    def put(self, msg: JSONObject) -> None:
        """A message the bridge emitted: kept when it is a sample of a wanted sensor."""
        if msg.get("t") == "s" and self.wanted(str(msg.get("r"))):
            self._queue(msg)
        elif msg.get("t") == "latch" and isinstance(msg.get("v"), dict):
            # the latched STOP's state (STOPPED by whom and when, released): channel latch
            v = cast(JSONObject, msg["v"])
            t = v.get("t")
            self._queue({"t": "l", "ts": t if isinstance(t, (int, float)) else time.time(),
                         "v": {k: x for k, x in v.items() if k != "t"}})
        elif msg.get("t") in ("log", "state", "link", "ls"):
            # log lines and state changes, a behavior's bearing, the link: native channels
            self._queue({"t": "m", "m": msg})

    def listen(self, bus: Bus, robot: str) -> None:
        """Record the commands ``robot``'s actuators run, from ``bus`` (until stop())."""
        sub = bus.subscribe(keys.commands_all(robot), self._on_commands, with_key=True)
        self._subs.append(functools.partial(bus.unsubscribe, sub))

    def _on_commands(self, key: str, obj: JSON) -> None:
        """A batch of an entry's command records (transport/records.py); items that are
        not records of that entry's actuators are counted dropped."""
        got, bad = records.unpack(key, obj)
        if bad:
            self.c.add("dropped", bad)
        for res, rec in got:
            if self.wanted(res):
                self._queue({"t": "c", "r": res, "m": rec})

    def _queue(self, msg: JSONObject) -> None:
        try:
            self.q.put_nowait(msg)
        except queue.Full:
            self.c.add("dropped")

    # ---- the writer thread
    def _run(self) -> None:
        while True:
            m = self.q.get()
            if m is None:
                return
            # the fields' types: what put() and _on_commands() checked, or a sample's
            if m["t"] == "c":
                self._write_command(cast(str, m["r"]), cast(JSONObject, m["m"]))
                continue
            if m["t"] == "m":
                self.writer.write_message(cast(JSONObject, m["m"]))
                continue
            if m["t"] == "l":
                self._latches += 1
                self.writer.write_latch(self._latches, float(cast(float, m["ts"])),
                                        cast(JSONObject, m["v"]))
                continue
            res, seq = cast(str, m["r"]), int(cast(int, m["q"]))
            last = self._last.get(res)
            if last is not None and seq != last + 1:
                self.c.add("gaps")
            self._last[res] = seq
            self.writer.write(res, seq, float(cast(float, m["ts"])), m["v"])
            self.c.add("written")

    def _write_command(self, res: str, rec: JSONObject) -> None:
        try:
            # a record's fields as records.unpack found them: anything but its v (an object)
            seq = int(cast("int | float | str", rec["seq"]))
            t = float(cast("int | float | str", rec["t"]))
            v = dict(cast(JSONObject, rec["v"]))
        except (KeyError, TypeError, ValueError):
            self.c.add("dropped")                  # not a command record
            return
        last = self._last_cmd.get(res)
        if last is not None and seq != last + 1:
            self.c.add("command_gaps")
        self._last_cmd[res] = seq
        self.writer.write_command(res, seq, t, v)
        self.c.add("commands")

    def stop(self) -> dict[str, int]:
        """Stop listening, write what is queued, close the file; the counters and the
        number of channels. While it listens to commands, it listens LINGER_S more first:
        a command's record leaves its host up to records.BATCH_S after the command ran,
        so the file holds every command run before the stop."""
        if self._subs:
            time.sleep(LINGER_S)
        for unsubscribe in self._subs:
            unsubscribe()
        self._subs.clear()
        self.q.put(None)
        if self._thread.is_alive():
            self._thread.join()
        self.writer.finish()
        self.f.close()
        return dict(self.c, channels=self.writer.data_channels)
