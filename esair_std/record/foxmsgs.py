"""What a running robot says, as Foxglove's channels (docs/foxglove.md): one converter for
the MCAP recording (tap.py) and the live Foxglove WebSocket server (foxserver.py).

:meth:`Converter.message` takes what a :class:`~esair_std.hmi.bridge.Bridge` emits (a
sample, a log line, a behavior's state, the link state) and :meth:`Converter.command`
a command record; each returns :class:`Out` messages. Every sample keeps its own channel
(the sensor's name, JSON, a schema of its fields: what replay reads); from the samples'
shapes, as the HMI's generic panels, come the native channels: a picture
``{format, image}`` -> ``foxglove.CompressedImage``, an odometry ``{x, y, th}`` ->
``foxglove.PoseInFrame`` and ``/tf`` (``world`` -> ``base_link``), a map ``{walls,
landmarks}`` -> ``foxglove.SceneUpdate`` (with a behavior's ``last.bearing`` as an arrow),
microphones ``{pcm, channels}`` -> their RMS level per channel, a servo's ``{angle}``
commands -> the joints, one message per change, a ``!R`` notice -> a reaction, log lines
-> ``foxglove.Log``. The Foxglove messages and schemas are the SDK's (foxglove-sdk)."""

from __future__ import annotations

import base64
import binascii
import json
import math
import operator
import sys
import time
from array import array
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

from foxglove import messages as fm

if TYPE_CHECKING:  # pragma: no cover
    from foxglove._foxglove_py import Schema as FoxSchema


class _Native(Protocol):
    """A Foxglove message class: it gives its schema."""

    @staticmethod
    def get_schema() -> FoxSchema: ...

JSON_TYPES = ["object", "array", "string", "number", "boolean", "null"]
UNITS = {"x": "m", "y": "m", "th": "rad", "distance": "m", "r": "m", "range_m": "m",
         "angle": "degrees", "bearing": "rad, from the robot's heading, counterclockwise",
         "t": "seconds since the epoch", "rate": "Hz"}
LEVELS = {"debug": fm.LogLevel.Debug, "info": fm.LogLevel.Info,
          "warning": fm.LogLevel.Warning, "error": fm.LogLevel.Error}

LOG_TOPIC, TF_TOPIC, LINK_TOPIC = "/log", "/tf", "/link"
COMMAND_TOPIC = "command/"


@dataclass(frozen=True)
class Schema:
    name: str
    encoding: str          # "jsonschema" or "protobuf"
    data: bytes

    @property
    def message_encoding(self) -> str:
        return "json" if self.encoding == "jsonschema" else "protobuf"


@dataclass(frozen=True)
class Out:
    topic: str
    schema: Schema
    data: bytes
    t: float               # log time, seconds since the epoch
    seq: int = 0


def json_schema(title: str, properties: dict[str, object], required: list[str] | None = None,
                extra: object = None) -> Schema:
    s: dict[str, object] = {"type": "object", "title": title, "properties": properties}
    if required:
        s["required"] = required
    if extra is not None:
        s["additionalProperties"] = extra
    return Schema(title, "jsonschema", json.dumps(s).encode())


def native(cls: _Native) -> Schema:
    s = cls.get_schema()
    return Schema(s.name, s.encoding, bytes(s.data))


def infer(value: object, key: str = "") -> dict[str, object]:
    """A JSON schema of ``value``'s shape (types, field names, units where known); a
    scalar field may also be null (a sensor that has no reading for once)."""
    out: dict[str, object]
    if isinstance(value, bool):
        out = {"type": ["boolean", "null"]}
    elif isinstance(value, (int, float)):
        out = {"type": ["number", "null"]}
    elif isinstance(value, str):
        out = {"type": ["string", "null"]}
    elif isinstance(value, list):
        out = {"type": "array"}
        if value and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
            out["items"] = {"type": "number"}
    elif isinstance(value, dict):
        out = {"type": "object", "properties": {k: infer(v, k) for k, v in value.items()}}
    else:
        out = {"type": JSON_TYPES}
    if key in UNITS:
        out["description"] = UNITS[key]
    return out


def sample_schema(sensor: str, value: object) -> Schema:
    """``{"seq", "t", "value"}`` with ``value``'s shape (schema ``esair.Sample.<sensor>``)."""
    return json_schema("esair.Sample." + sensor, {
        "seq": {"type": "integer", "description": "the sensor's sample number, from 1"},
        "t": {"type": "number", "description": "seconds since the epoch, when reported"},
        "value": infer(value)}, ["seq", "t", "value"])


COMMAND = json_schema("esair.Command", {
    "seq": {"type": "integer", "description": "the actuator's command number, from 1"},
    "t": {"type": "number", "description": "seconds since the epoch, when it reached the "
                                           "actuator's host"},
    "command": {"type": JSON_TYPES, "description": "the command as sent"},
    "ok": {"type": JSON_TYPES, "description": "the actuator's answer (the command ran)"},
    "error": {"type": "string", "description": "why it failed"},
    "by": {"type": "string", "description": "its sender: a behavior, operator, hmi, ..."}},
    ["seq", "t", "command"])
LINK = json_schema("esair.Link", {
    "entry": {"type": "string", "description": "the MIN link's resource entry"},
    "state": {"type": "string", "description": "ready, lost or gone"},
    "reason": {"type": "string"}}, ["entry", "state", "reason"])
REACTION = json_schema("esair.Reaction", {
    "reaction": {"type": "string", "description": "the firmware reaction's name (its !R line)"},
    "text": {"type": "string", "description": "the whole notice"}}, ["reaction", "text"])
JOINTS = json_schema("esair.Joints", {
    "t": {"type": "number", "description": "seconds since the epoch, when the change ran"}},
    ["t"], {"type": "number", "description": "the joint's commanded angle, degrees"})
LOG, POSE, TF = native(fm.Log), native(fm.PoseInFrame), native(fm.FrameTransform)
IMAGE, SCENE = native(fm.CompressedImage), native(fm.SceneUpdate)


def levels_schema(n: int) -> Schema:
    return json_schema(f"esair.MicLevels{n}", {
        f"mic{i}": {"type": "number", "description": "RMS level of the frame, full scale = 1"}
        for i in range(n)}, [f"mic{i}" for i in range(n)])


def _js(obj: object) -> bytes:
    return json.dumps(obj, separators=(",", ":")).encode()


def _stamp(t: float) -> fm.Timestamp:
    sec = int(t)
    return fm.Timestamp(sec=sec, nsec=min(999_999_999, int((t - sec) * 1e9)))


def _yaw(th: float) -> fm.Quaternion:
    return fm.Quaternion(x=0.0, y=0.0, z=math.sin(th / 2), w=math.cos(th / 2))


def _color(rgb: object, a: float = 1.0) -> fm.Color:
    r, g, b = (list(rgb) + [128, 128, 128])[:3] if isinstance(rgb, list) else (128, 128, 128)
    return fm.Color(r=r / 255, g=g / 255, b=b / 255, a=a)


def _num(v: object) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


class Converter:
    """Bridge messages and command records -> :class:`Out` (one thread at a time)."""

    def __init__(self) -> None:
        self.schemas: dict[str, Schema] = {}       # a sample's topic -> its schema
        self.joints: dict[str, dict[str, float]] = {}    # entry -> joint -> angle
        self.room: dict[str, dict] = {}            # entry -> its map sample
        self.link: dict[str, tuple[str, str]] = {}
        self.states_told = False

    def message(self, msg: dict) -> list[Out]:
        kind = msg.get("t")
        if kind == "s":
            return self.sample(str(msg.get("r")), int(msg.get("q") or 0),
                               float(msg.get("ts") or 0.0), msg.get("v"))
        if kind == "log":
            return [self.log(str(msg.get("level")), str(msg.get("text")),
                             float(msg.get("ts") or 0.0))]
        if kind == "state":
            return self.state(str(msg.get("r")), msg.get("v"))
        if kind == "ls" and isinstance(msg.get("rows"), list) and not self.states_told:
            # the components' states when the recording starts (their changes after it
            # come as the bridge's log lines)
            self.states_told = True
            return [self.log("info", f"{r.get('name')}: {r.get('state')}", time.time(),
                             str(r.get("name"))) for r in msg["rows"] if isinstance(r, dict)]
        if kind == "link" and isinstance(msg.get("link"), dict):
            return self.links(msg["link"])
        return []

    def log(self, level: str, text: str, t: float, name: str = "esair") -> Out:
        m = fm.Log(timestamp=_stamp(t), level=LEVELS.get(level, fm.LogLevel.Info),
                   message=text, name=name, file="", line=0)
        return Out(LOG_TOPIC, LOG, m.encode(), t)

    def links(self, link: dict) -> list[Out]:
        out = []
        for entry, info in link.items():
            now = (str(info.get("state", "")), str(info.get("reason") or ""))
            if self.link.get(entry) != now:
                self.link[entry] = now
                out.append(Out(LINK_TOPIC, LINK, _js({"entry": entry, "state": now[0],
                                                      "reason": now[1]}), time.time()))
        return out

    def command(self, actuator: str, seq: int, t: float, rec: dict) -> list[Out]:
        out = [Out(COMMAND_TOPIC + actuator, COMMAND, _js(dict(rec, seq=seq, t=t)), t, seq)]
        cmd = rec.get("command")
        if "ok" in rec and ".servo." in actuator and isinstance(cmd, dict) and _num(cmd.get("angle")):
            entry, joint = actuator.split(".servo.", 1)
            joints = self.joints.setdefault(entry, {})
            if joints.get(joint) != cmd["angle"]:
                joints[joint] = float(cmd["angle"])
                out.append(Out(f"/{entry}/joints", JOINTS, _js(dict(joints, t=t)), t))
        return out

    def sample(self, sensor: str, seq: int, t: float, v: object) -> list[Out]:
        schema = self.schemas.get(sensor)
        if schema is None:
            schema = self.schemas[sensor] = sample_schema(sensor, v)
        out = [Out(sensor, schema, _js({"seq": seq, "t": t, "value": v}), t, seq)]
        if not isinstance(v, dict):
            return out
        entry = sensor.split(".", 1)[0]
        if isinstance(v.get("image"), str) and isinstance(v.get("format"), str):
            out += self._picture(entry, t, v)
        elif all(_num(v.get(k)) for k in ("x", "y", "th")):
            out += self._pose(entry, t, v)
        elif isinstance(v.get("walls"), list) and isinstance(v.get("landmarks"), list):
            self.room[entry] = v
            out.append(self._scene(entry, t, v))
        elif isinstance(v.get("pcm"), str) and isinstance(v.get("channels"), int):
            out += self._levels(sensor, t, v)
        elif isinstance(v.get("notice"), str) and v["notice"].startswith("R"):
            text = v["notice"]
            name = text[1:].strip().split(" ", 1)[0] if len(text) > 1 else ""
            out.append(Out(f"/{entry}/reactions", REACTION,
                           _js({"reaction": name, "text": text}), t))
        return out

    def state(self, behavior: str, v: object) -> list[Out]:
        """A behavior's state with a bearing (``last: {bearing, t}``): an arrow on every
        room's scene, from the robot (frame ``base_link``)."""
        last = v.get("last") if isinstance(v, dict) else None
        if not isinstance(last, dict) or not _num(last.get("bearing")):
            return []
        t = float(last["t"]) if _num(last.get("t")) else 0.0
        arrow = fm.ArrowPrimitive(pose=fm.Pose(position=fm.Vector3(x=0.0, y=0.0, z=0.1),
                                               orientation=_yaw(float(last["bearing"]))),
                                  shaft_length=0.8, shaft_diameter=0.03, head_length=0.15,
                                  head_diameter=0.08, color=fm.Color(r=1.0, g=0.3, b=0.1, a=1.0))
        ent = fm.SceneEntity(timestamp=_stamp(t), frame_id="base_link", id=f"bearing:{behavior}",
                             frame_locked=True, arrows=[arrow])
        return [Out(f"/{entry}/scene", SCENE, fm.SceneUpdate(entities=[ent]).encode(), t)
                for entry in self.room]

    # ---- the native shapes
    def _picture(self, entry: str, t: float, v: dict) -> list[Out]:
        try:
            data = base64.b64decode(v["image"], validate=True)
        except (binascii.Error, ValueError):
            return []
        ts = float(v["t"]) if _num(v.get("t")) else t
        m = fm.CompressedImage(timestamp=_stamp(ts), frame_id="camera", data=data,
                               format=str(v["format"]))
        return [Out(f"/{entry}/camera", IMAGE, m.encode(), t)]

    def _pose(self, entry: str, t: float, v: dict) -> list[Out]:
        x, y, th = float(v["x"]), float(v["y"]), float(v["th"])
        pose = fm.Pose(position=fm.Vector3(x=x, y=y, z=0.0), orientation=_yaw(th))
        p = fm.PoseInFrame(timestamp=_stamp(t), frame_id="world", pose=pose)
        tf = fm.FrameTransform(timestamp=_stamp(t), parent_frame_id="world",
                               child_frame_id="base_link",
                               translation=fm.Vector3(x=x, y=y, z=0.0), rotation=_yaw(th))
        return [Out(f"/{entry}/pose", POSE, p.encode(), t), Out(TF_TOPIC, TF, tf.encode(), t)]

    def _scene(self, entry: str, t: float, v: dict) -> Out:
        walls = [fm.LinePrimitive(type=fm.LinePrimitiveLineType.LineList, thickness=0.05,
                                  scale_invariant=False, color=fm.Color(r=0.8, g=0.8, b=0.8, a=1.0),
                                  points=[p for w in v["walls"] if isinstance(w, list) and len(w) == 4
                                          for p in (fm.Point3(x=float(w[0]), y=float(w[1]), z=0.0),
                                                    fm.Point3(x=float(w[2]), y=float(w[3]), z=0.0))])]
        cylinders, spheres = [], []
        for lm in v["landmarks"]:
            if not isinstance(lm, dict) or not (_num(lm.get("x")) and _num(lm.get("y"))):
                continue
            at = fm.Pose(position=fm.Vector3(x=float(lm["x"]), y=float(lm["y"]), z=0.25),
                         orientation=_yaw(0.0))
            kind = lm.get("kind")
            if kind == "pole":
                d = 2 * float(lm.get("r", 0.1))
                cylinders.append(fm.CylinderPrimitive(pose=at, size=fm.Vector3(x=d, y=d, z=0.5),
                                                      bottom_scale=1.0, top_scale=1.0,
                                                      color=_color(lm.get("color"))))
            elif kind == "access_point":
                spheres.append(fm.SpherePrimitive(pose=at, size=fm.Vector3(x=0.2, y=0.2, z=0.2),
                                                  color=fm.Color(r=0.2, g=0.6, b=1.0, a=1.0)))
            elif kind == "sound" and lm.get("on", True):
                spheres.append(fm.SpherePrimitive(pose=at, size=fm.Vector3(x=0.25, y=0.25, z=0.25),
                                                  color=fm.Color(r=1.0, g=0.2, b=0.2, a=1.0)))
        ent = fm.SceneEntity(timestamp=_stamp(t), frame_id="world", id="room",
                             lines=walls, cylinders=cylinders, spheres=spheres)
        return Out(f"/{entry}/scene", SCENE, fm.SceneUpdate(entities=[ent]).encode(), t)

    def _levels(self, sensor: str, t: float, v: dict) -> list[Out]:
        """The RMS level of each channel of one frame of interleaved 16-bit PCM (no
        numpy: it would add ~14 MB to the live server's RSS)."""
        n = v["channels"]
        if n <= 0:
            return []
        try:
            pcm = array("h", base64.b64decode(v["pcm"]))
        except (binascii.Error, ValueError):
            return []
        if sys.byteorder == "big":
            pcm.byteswap()                       # the frames are little-endian
        frames = len(pcm) // n
        if not frames:
            return []
        levels = {}
        for i in range(n):
            ch = pcm[i:frames * n:n]
            levels[f"mic{i}"] = round(math.sqrt(sum(map(operator.mul, ch, ch)) / frames) / 32768, 6)
        return [Out(f"/{sensor.replace('.', '/')}/levels", levels_schema(n), _js(levels), t)]
