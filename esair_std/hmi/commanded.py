"""What the robot was last told, as the HMI's pages show it (the pose and the sliders).

:class:`PoseBook` keeps, per actuator, the last command that went through, in the order
they went, and for each motion actuator the motion with when it started and when a STOP
stopped it: a page opened later rebuilds the pose from these (``hello``), a motion at the
frame it had reached. Commands come two ways: the actuators' records of every command
they ran (any sender: ``ran``) and this HMI's own commands once answered (``sent``).
The two race (the record on Zenoh's thread, the answer through the control endpoint);
whichever comes first shows the command and gives a motion its start (or STOP) time, the
other is not shown again. The book only computes: it returns the message the pages get,
the HMI server sends it (server.py). One thread (the server's loop) calls it.
"""

from __future__ import annotations

import collections
import json

from ..transport.codec import JSON, JSONObject

OWN_MAX = 64                # this HMI's commands whose records are still due

#: motion actuator -> (the motion command that went through, when, when stopped or None)
Played = tuple[JSON, float, "float | None"]


def _key(res: str, command: JSON) -> str:
    return json.dumps([res, command], sort_keys=True)


class PoseBook:
    def __init__(self) -> None:
        self.commanded: dict[str, JSON] = {}     # resource -> last command that went through
        self.played: dict[str, Played] = {}
        self.own: collections.deque[str] = collections.deque(maxlen=OWN_MAX)  # sent, record due
        self.asking: list[str] = []             # this HMI's commands not answered yet
        self.early: collections.deque[str] = collections.deque(maxlen=OWN_MAX)  # ... whose record came first

    # ---- this HMI's commands
    def asked(self, res: str, command: JSON) -> str:
        """A command of this HMI is sent (its record may come before its answer)."""
        text = _key(res, command)
        self.asking.append(text)
        return text

    def answered(self, text: str) -> None:
        """Its answer came (went through or refused): no longer waited for."""
        if text in self.asking:
            self.asking.remove(text)

    def sent(self, res: str, command: JSON, at: float) -> JSONObject | None:
        """A command of this HMI went through (``at``: when its answer came): the message
        to show it now, its record skipped later; None when its record came first (shown
        already)."""
        text = _key(res, command)
        if text in self.early:
            self.early.remove(text)
            return None
        self.own.append(text)
        return self._commanded(res, command, at)

    # ---- every sender's records
    def ran(self, res: str, command: JSON, at: float) -> JSONObject | None:
        """An actuator's record of a command it ran (``at``: when the robot took it): the
        message to send, or None. Shown as commanded, except the record of a command this
        HMI sent, shown when it was answered (a remote HMI whose ACL reads no records still
        shows its own); whichever of the two comes first gives a motion its start (or
        STOP) time."""
        text = _key(res, command)
        if text in self.own:
            self.own.remove(text)
            return self._earlier(res, command, at)
        if text in self.asking:          # its answer is still on its way: shown now
            self.asking.remove(text)
            self.early.append(text)
        return self._commanded(res, command, at)

    def _earlier(self, res: str, command: JSON, at: float) -> JSONObject | None:
        """The record of this HMI's motion command came after its answer but says the
        robot took it earlier: the motion's start or STOP time is the record's. A STOP's
        corrected position is the message to send."""
        played = self.played.get(res)
        if played is None or not res.endswith(".motion"):
            return None
        cmd, t0, t1 = played
        if command == "stop" and t1 is not None and at < t1:
            self.played[res] = (cmd, t0, max(t0, at))
            return {"t": "commanded", "r": res, "v": command, "played": self.played_at(res, at)}
        if command == cmd and t1 is None and at < t0:
            self.played[res] = (cmd, at, None)
        return None

    def _commanded(self, res: str, command: JSON, now: float) -> JSONObject:
        msg: JSONObject = {"t": "commanded", "r": res, "v": command}
        if res.endswith(".motion"):
            played = self.played.get(res)
            if command == "stop":
                if played is not None:
                    # the motion's entry is kept, with the time it was stopped: the frame a
                    # page shows is the one the motion had reached (pages open and opened later)
                    if played[2] is None:
                        self.played[res] = (played[0], played[1], max(now, played[1]))
                    msg["played"] = self.played_at(res, now)
                # a STOP moves nothing: the pose stays what the last commands made it
                return msg
            entry = res[: -len(".motion")]      # a motion moves every servo of its robot
            for key in [k for k in self.commanded if k.startswith(entry + ".servo.")]:
                del self.commanded[key]
            self.played[res] = (command, now, None)
        self.commanded.pop(res, None)
        self.commanded[res] = command
        return msg

    # ---- what a page is shown
    def played_at(self, res: str, now: float) -> JSONObject:
        """Where the motion commanded on ``res`` is: ``{"v": command, "ms": time it has
        played (up to its STOP), "stopped": bool}``."""
        command, t0, t1 = self.played[res]
        return {"v": command, "ms": round(((t1 or now) - t0) * 1000, 1), "stopped": t1 is not None}

    def hello(self, now: float) -> list[JSON]:
        """The commands a new page rebuilds the pose from, in the order they went
        through: ``[resource, command]``, a motion's with ``played`` (played_at) third."""
        return [[res, v, self.played_at(res, now)] if res in self.played else [res, v]
                for res, v in self.commanded.items()]
