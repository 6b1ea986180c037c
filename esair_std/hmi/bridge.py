"""The HMI's side of the runtime: one Zenoh session to the control endpoint.

The principal ``hmi`` registers with the RS like any behavior: ``watch`` (read) on every
sensor the deployment's ``allow`` lets it read, ``command`` only where ``allow`` grants
``hmi: command``. What it asks of the runtime costs the runtime's CPU (in thread mode,
the robot's link runs on the same interpreter), so it asks little:

- ``ls`` (component states) when the runtime's notice says a state changed
  (``esair/<robot>/changed``, control/control_server.py) or its liveliness token comes or goes,
  and at least every LS_SAFETY_S (what sends no notice: a behavior's ``busy`` flag,
  attachments; a runtime without notices): a lost link shows as soon as the runtime
  knows it;
- ``inspect`` of each link entry (its counters: commands/s, errors) every INSPECT_S,
  and each running behavior's ``get`` (its state: the page shows it, e.g. a bearing)
  every STATE_PERIOD_S, both only while a page shows them (``showing()``, told by the
  server); a behavior that is ``busy`` takes no ``get``;
- the link bar's reply ages come from the samples this process got (every TICK_S, no
  request).

Samples arrive on Zenoh's thread. The last sample of each sensor and the last state of
each behavior are kept for the ``hello`` of a page opened later. Everything goes out
through ``emit(message)``, which must only hand the message over (the server's loop
writes it to every open page's socket).
"""

from __future__ import annotations

import json
import logging
import os
import threading
import time
from typing import Callable, cast

from ..counters import Counters
from ..errors import StdError, TransportError
from ..transport import keys, records
from ..transport.bus import Bus
from ..transport.codec import JSON, JSONObject
from ..transport.session import check_endpoint

log = logging.getLogger("esair_std.hmi")
TICK_S = 0.25              # the link bar's reply ages (no request)
LS_SAFETY_S = 1.0          # ls at least this often (changes the runtime sends no notice of)
LS_MIN_S = 0.05            # ... and at most this often (a burst of notices)
INSPECT_S = 2.0            # the link entries' counters, while a page shows them
PRINCIPAL = "hmi"
STATE_PERIOD_S = 0.5       # each running behavior's get, this often, while a page shows it
STATE_TIMEOUT_S = 0.3

Emit = Callable[[JSONObject], None]


class BridgeError(StdError):
    """The runtime cannot be reached or refused the HMI."""


class Bridge:
    def __init__(self, endpoint: str, emit: Emit, who: str = PRINCIPAL,
                 session_options: JSONObject | None = None,
                 on_commands: Callable[[str, JSON], None] | None = None):
        self.endpoint = check_endpoint(endpoint)
        self.emit = emit
        # the command records whole (key, batch), instead of ``ran`` messages (the live
        # Foxglove server: one subscription, not two)
        self.on_commands = on_commands
        self.who = who
        if session_options is None:
            extra = os.environ.get("ESAIR_STD_SESSION") or "{}"
            try:
                session_options = json.loads(extra)
            except ValueError:
                raise BridgeError("ESAIR_STD_SESSION is not a JSON object") from None
        self.options = session_options
        self.bus: Bus | None = None
        self.robot = ""
        self.robots: JSONObject = {}          # MIN link entry -> robot_info
        self.links: list[str] = []            # every MIN link entry (robots' and others')
        self.problems: list[str] = []
        self.rows: list[JSONObject] = []
        self.watched: dict[str, str] = {}     # sensor -> "ok" or the refusal
        self.link: dict[str, JSONObject] = {}
        self.runtime_up = False
        self.latch: JSONObject = {"stopped": False}     # the runtime's latched STOP (latch.py)
        self._last_sample: dict[str, float] = {}
        self._prev_counts: dict[str, tuple[float, int, int]] = {}
        self._stop = threading.Event()
        self._kick = threading.Event()        # ls now: the runtime said a state changed
        self._asked = 0.0                     # when ls was last answered (monotonic)
        self._poll_lock = threading.Lock()    # one ls at a time (poller, refresh())
        self._thread: threading.Thread | None = None
        self._state_thread: threading.Thread | None = None
        self.last: dict[str, JSONObject] = {}     # sensor -> its last sample message
        self.states: dict[str, JSON] = {}     # behavior -> its last get value
        self.c = Counters(samples=0, samples_unwatched=0, ls_failed=0, gets_failed=0,
                          commands_seen=0, records_refused=0, notices=0, ls=0, inspects=0,
                          gets=0)
        self.want: Callable[[str], bool] = lambda name: True    # the sensors to watch
        self.showing: Callable[[], bool] = lambda: True         # a page shows what we ask
        # the link entries' counters (inspect) and reply ages (every TICK_S) are the link
        # bar's: an owner without one (the live Foxglove server) asks none, ticks seldom
        self.link_bar = True

    # ---- life cycle
    def start(self) -> None:
        try:
            self.bus = Bus(connect=[self.endpoint], options=self.options,
                           runtime=self.endpoint)
        except TransportError as exc:
            raise BridgeError(f"cannot open a session to {self.endpoint}: {exc}") from None
        robot = self.bus.runtime_robot()
        if robot is None:
            self.bus.close()
            raise BridgeError(f"no ESAIR STD runtime answers on {self.endpoint} "
                              "(is `esair std run` running?)")
        self.robot = robot
        self.runtime_up = True
        d = self.ask("describe")        # the runtime reads the board files, not this process
        self.robots = cast(JSONObject, d.get("robots", {}))
        self.problems = cast("list[str]", d.get("problems", []))
        # a driver derived from MinLink (STARFISH's) has a link too, board files or not
        links = cast("list[str]", d.get("links", []))
        self.links = list(self.robots) + [e for e in links if e not in self.robots]
        self.bus.subscribe(f"esair/{self.robot}/sensor/**", self._on_sample, with_key=True)
        if self.on_commands is None:
            self._held()
        # every command an actuator ran, whoever sent it (a behavior, `esair std put`,
        # another page): the pose shows what the robot was told, not only this HMI's
        self.bus.subscribe(keys.commands_all(self.robot), self.on_commands or self._on_commands,
                           with_key=True)
        # ls when told: a state changed, or the runtime came or went
        self.bus.subscribe(keys.changed(self.robot), self._on_changed)
        # the latched STOP: asked now (an HMI started while it holds shows it), then
        # told at each change
        self.bus.subscribe(keys.latch(self.robot), self._on_latch)
        self.latch = self.ask("latch")
        self.bus.watch_alive(keys.alive(self.robot, "runtime", "runtime"),
                             lambda _key, _alive: self._kick.set())
        self._poll_once(inspect=True)
        self._thread = threading.Thread(target=self._run, name="hmi:poll", daemon=True)
        self._thread.start()
        self._state_thread = threading.Thread(target=self._run_states, name="hmi:state",
                                              daemon=True)
        self._state_thread.start()

    def close(self) -> None:
        self._stop.set()
        self._kick.set()
        for t in (self._thread, self._state_thread):
            if t is not None:
                t.join(2.0)
        if self.bus is not None:
            self.bus.close()

    # ---- requests
    def counters(self) -> dict[str, int]:
        """Its counters, and ``foreign_answers``: control answers from another runtime
        of the robot's name than the one at the endpoint, ignored (transport/bus.py)."""
        bus = self.bus
        return dict(self.c.snapshot(), foreign_answers=bus.c["foreign_answers"] if bus is not None else 0)

    def call(self, verb: str, body: JSONObject | None = None, timeout: float = 5.0) -> JSON:
        """One control request; the ``ok`` value, or BridgeError with the runtime's
        message (the error's type prefixed when it is a refusal)."""
        assert self.bus is not None
        # a control answer is an object: {"ok": value} or {"error": why}
        r = cast("JSONObject | None", self.bus.request(keys.ctl(self.robot, verb), body or {},
                                                       timeout))
        if r is None:
            raise BridgeError(f"the runtime did not answer {verb!r} within {timeout:g} s")
        if "error" in r:
            raise BridgeError(str(r["error"]))
        return r.get("ok")

    def ask(self, verb: str, body: JSONObject | None = None,
            timeout: float = 5.0) -> JSONObject:
        """``call`` of a verb whose ``ok`` value is an object (describe, latch, inspect,
        get: control/control_server.py)."""
        return cast(JSONObject, self.call(verb, body, timeout))

    def command(self, resource: str, command: JSON, timeout: float = 2.0) -> JSON:
        return self.call("command", {"who": self.who, "resource": resource,
                                     "command": command, "timeout": timeout},
                         timeout=timeout + 3.0)

    def hello(self) -> JSONObject:
        """What a newly connected page gets first."""
        return {"t": "hello", "robot": self.robot, "robots": self.robots,
                "problems": [*self.problems], "rows": [*self.rows], "link": {**self.link},
                "watched": {**self.watched}, "runtime_up": self.runtime_up,
                "last": [*self.last.values()], "latch": self.latch,
                "states": [{"t": "state", "r": k, "v": v} for k, v in self.states.items()]}

    # ---- commands and samples (Zenoh's thread: hand over and return)
    def _on_changed(self, obj: JSON) -> None:
        self.c.add("notices")
        self._kick.set()

    def _on_latch(self, obj: JSON) -> None:
        if isinstance(obj, dict) and isinstance(obj.get("stopped"), bool):
            self.latch = obj
            self.emit({"t": "latch", "v": obj})

    def _on_commands(self, key: str, obj: JSON) -> None:
        """A batch of an entry's command records (transport/records.py): each command
        that went through is handed on as ``{"t": "ran", "r": actuator, "v": command}``."""
        got, bad = records.unpack(key, obj)
        if bad:
            self.c.add("records_refused", bad)
        for res, rec in got:
            v: JSON = rec["v"]              # an object (records.unpack checked it)
            if isinstance(v, dict) and "ok" in v and "command" in v:
                self.c.add("commands_seen")
                self.emit({"t": "ran", "r": res, "v": v["command"], "at": took(v["ok"])})

    def _held(self) -> None:
        """What each robot was last told before this HMI started (its actuators' last
        commands that went through, kept by their host: ``last_ok`` in ``inspect``),
        handed on as ``ran`` in the order they went, before any live record: the pose a
        page shows is the one the robot holds, not every joint at its default."""
        held: list[tuple[float, str, JSON]] = []
        for entry in self.robots:
            try:
                c = cast(JSONObject, self.ask("inspect", {"name": entry}, timeout=2.0)
                         .get("counters", {}))
            except BridgeError as exc:
                log.warning("hmi: %s's last commands not known: %s", entry, exc)
                continue
            for res, slot in c.items():       # the entry's actuators: "<entry>.<child>"
                if (res.startswith(entry + ".") and isinstance(slot, dict)
                        and isinstance(slot.get("last_ok"), list)):
                    # [when, command, its answer] each (hosts' last_ok)
                    for t, command, ok in cast("list[tuple[float, JSON, JSON]]",
                                               slot["last_ok"]):
                        held.append((took(ok, t), res, command))
        for at, res, command in sorted(held, key=lambda h: h[0]):
            self.emit({"t": "ran", "r": res, "v": command, "at": at})

    def _on_sample(self, key: str, obj: JSON) -> None:
        res = key.rsplit("/sensor/", 1)[-1]
        if self.watched.get(res) != "ok" or not isinstance(obj, dict):
            self.c.add("samples_unwatched")
            return
        self.c.add("samples")
        now = self._last_sample[res] = time.time()
        # rx: when this process got it (the page splits sample -> pixel at it, docs/hmi.md)
        msg: JSONObject = {"t": "s", "r": res, "q": obj.get("seq"), "ts": obj.get("t"), "v": obj.get("v"),
               "rx": round(now, 4)}
        self.last[res] = msg          # one reference per sensor: replaced, never grows
        self.emit(msg)

    # ---- the poller
    def _run(self) -> None:
        """ls when told (a notice, the runtime's token) or LS_SAFETY_S after the last;
        inspect every INSPECT_S while a page shows it; else every TICK_S the link bar's
        reply ages from the rows as they are."""
        tick = inspected = time.monotonic()
        while not self._stop.is_set():
            now = time.monotonic()
            kicked = self._kick.wait(max(0.0, min(tick, self._asked + LS_SAFETY_S) - now))
            if self._stop.is_set():
                return
            now = time.monotonic()
            if kicked and now - self._asked < LS_MIN_S:      # a burst of notices: one ls
                self._stop.wait(LS_MIN_S - (now - self._asked))
                now = time.monotonic()
            inspect = self.link_bar and self.showing() and now - inspected >= INSPECT_S
            if inspect:
                inspected = now
            try:
                if kicked or now - self._asked >= LS_SAFETY_S:
                    self._kick.clear()
                    self._poll_once(inspect=inspect)
                elif inspect or now >= tick:
                    with self._poll_lock:
                        self._link(self.rows, inspect=inspect)
            except Exception as exc:  # noqa: BLE001 - keep polling
                log.error("hmi poll: %s", exc)
            if now >= tick:
                tick = now + (TICK_S if self.link_bar else LS_SAFETY_S)

    def _run_states(self) -> None:
        while not self._stop.wait(STATE_PERIOD_S):
            if not self.showing():
                continue
            try:
                self._states_once()
            except Exception as exc:  # noqa: BLE001 - keep polling
                log.error("hmi states: %s", exc)

    def _states_once(self) -> None:
        """Each running behavior's ``get`` (as ``esair std get`` shows it, asked as the
        principal ``hmi``); a change is emitted as ``{"t": "state", "r", "v"}``."""
        rows = self.rows
        running = {str(r["name"]) for r in rows
                   if r["kind"] == "behavior" and r["state"] in ("running", "busy")}
        for name in list(self.states):
            if name not in running:
                del self.states[name]
        busy = {str(r["name"]) for r in rows if r["state"] == "busy"}    # it would not answer
        for name in sorted(running - busy):
            self.c.add("gets")
            try:
                r = self.ask("get", {"from": self.who, "to": name, "timeout": STATE_TIMEOUT_S},
                              timeout=STATE_TIMEOUT_S + 1.0)
            except BridgeError:
                self.c.add("gets_failed")
                continue
            if not r.get("ok"):
                self.c.add("gets_failed")
                continue
            value = r.get("data")
            if name not in self.states or self.states[name] != value:
                self.states[name] = value
                self.emit({"t": "state", "r": name, "v": value})

    def _poll_once(self, inspect: bool) -> None:
        with self._poll_lock:
            self._poll_locked(inspect)

    def _poll_locked(self, inspect: bool) -> None:
        self.c.add("ls")
        try:
            rows = cast("list[JSONObject]",                      # as `esair std ls` shows
                        self.call("ls", {"all": True}, timeout=1.0))
        except BridgeError as exc:
            self._asked = time.monotonic()
            self.c.add("ls_failed")
            if self.runtime_up:
                self.runtime_up = False
                self.emit({"t": "runtime", "up": False, "reason": str(exc)})
                self.emit(_log("error", f"runtime not answering: {exc}"))
            return
        self._asked = time.monotonic()
        if not self.runtime_up:
            self.runtime_up = True
            self.emit({"t": "runtime", "up": True, "reason": ""})
            self.emit(_log("info", "runtime answers again"))
            try:                      # a notice of the STOP may have been missed meanwhile
                self._on_latch(self.call("latch", timeout=1.0))
            except BridgeError:
                pass
        self._changes(self.rows, rows)
        if rows != self.rows:
            self.rows = rows
            self.emit({"t": "ls", "rows": cast("list[JSON]", rows)})
        self._watch_new(rows)
        self._link(rows, inspect)

    def _changes(self, old: list[JSONObject], new: list[JSONObject]) -> None:
        before = {str(r["name"]): r for r in old}
        for r in new:
            prev = before.pop(str(r["name"]), None)
            if prev is None:
                if old:
                    self.emit(_log("info", f"{r['name']}: added ({r['kind']}, {r['state']})"))
            elif prev["state"] != r["state"]:
                level = "error" if r["state"] in ("failed", "lost") else "info"
                why = f": {r['reason']}" if r.get("reason") else ""
                self.emit(_log(level, f"{r['name']}: {prev['state']} -> {r['state']}{why}"))
        for name in before:
            self.emit(_log("info", f"{name}: removed"))

    def _watch_new(self, rows: list[JSONObject]) -> None:
        present = {str(r["name"]) for r in rows
                   if r["kind"] == "sensor" and self.want(str(r["name"]))}
        for name in list(self.watched):
            if name not in present:
                del self.watched[name]        # removed: watched again if it comes back
        for name in sorted(present - set(self.watched)):
            try:
                self.call("watch", {"who": self.who, "resource": name})
                self.watched[name] = "ok"
            except BridgeError as exc:
                self.watched[name] = str(exc)
                self.emit(_log("warning", f"{name}: not shown: {exc}"))
            self.emit({"t": "watched", "watched": {**self.watched}})

    def _link(self, rows: list[JSONObject], inspect: bool) -> None:
        """Per MIN link entry: state, last reply age, commands/s, errors."""
        now = time.time()
        out: dict[str, JSONObject] = {}
        for entry in self.links:
            mine = [r for r in rows if str(r["name"]).startswith(entry + ".")]
            if not mine:
                out[entry] = {"state": "gone", "reason": "not deployed"}
                continue
            lost = [r for r in mine if r["state"] != "ready"]
            state = "ready" if not lost else "lost"
            reason = lost[0].get("reason", "") if lost else ""
            info = dict(self.link.get(entry, {}))
            info.update(state=state, reason=reason, host=mine[0].get("host"),
                        pid=mine[0].get("pid"))
            last = max((t for r, t in self._last_sample.items()
                        if r.startswith(entry + ".")), default=None)
            info["reply_age_s"] = None if last is None else round(now - last, 3)
            if inspect:
                self._counters(entry, info, now)
            out[entry] = info
        if out != self.link:
            for entry, info in out.items():
                before = self.link.get(entry, {}).get("state")
                if before is not None and before != info["state"]:
                    self.emit(_log("error" if info["state"] != "ready" else "info",
                                   f"link {entry}: {info['state']}"
                                   + (f" ({info['reason']})" if info["reason"] else "")))
            self.link = out
            self.emit({"t": "link", "link": {**out}})

    def _counters(self, entry: str, info: JSONObject, now: float) -> None:
        self.c.add("inspects")
        try:
            c = cast("dict[str, object]",
                     self.ask("inspect", {"name": entry}, timeout=1.0).get("counters", {}))
        except BridgeError:
            return
        cmds = sum(v.get("commands", 0) for v in c.values() if isinstance(v, dict))
        errs = sum(v.get("command_errors", 0) for v in c.values() if isinstance(v, dict))
        prev = self._prev_counts.get(entry)
        self._prev_counts[entry] = (now, cmds, errs)
        if prev is not None and 0 < now - prev[0] <= 2 * INSPECT_S:
            info["commands_per_s"] = round((cmds - prev[1]) / (now - prev[0]), 1)
        else:                 # the first, or after a spell with no page: no rate yet
            info.pop("commands_per_s", None)
        info["commands"] = cmds
        info["errors"] = errs


def took(result: JSON, default: float | None = None) -> float:
    """When the robot took a command: its driver's ``at`` (a MIN link's motion: when the
    robot had the whole line, docs/std-papaman.md), else ``default`` or now (when its
    answer or record came)."""
    at = result.get("at") if isinstance(result, dict) else None
    if isinstance(at, (int, float)) and not isinstance(at, bool):
        return float(at)
    return time.time() if default is None else default


def _log(level: str, text: str) -> JSONObject:
    return {"t": "log", "level": level, "text": text, "ts": time.time()}
