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
-> ``foxglove.Log``. The Foxglove messages are encoded by foxproto.py (their schemas are
foxglove-sdk's, shipped in foxschemas.py). A message's bytes are made when first asked
for (:attr:`Out.data`): the live server asks only for channels a client subscribes to."""

from __future__ import annotations

import base64
import binascii
import json
import math
import sys
import time
from array import array
from dataclasses import dataclass
from typing import Callable

from . import foxproto as fp

JSON_TYPES = ["object", "array", "string", "number", "boolean", "null"]
UNITS = {"x": "m", "y": "m", "th": "rad", "distance": "m", "r": "m", "range_m": "m",
         "angle": "degrees", "bearing": "rad, from the robot's heading, counterclockwise",
         "t": "seconds since the epoch", "rate": "Hz"}

LOG_TOPIC, TF_TOPIC, LINK_TOPIC, LATCH_TOPIC = "/log", "/tf", "/link", "latch"
COMMAND_TOPIC = "command/"


@dataclass(frozen=True)
class Schema:
    name: str
    encoding: str          # "jsonschema" or "protobuf"
    data: bytes

    @property
    def message_encoding(self) -> str:
        return "json" if self.encoding == "jsonschema" else "protobuf"


class Out:
    """One message of channel ``topic``: ``data`` (its bytes, or what makes them on
    first use), ``t`` its log time (seconds since the epoch)."""
    __slots__ = ("_data", "_make", "schema", "seq", "t", "topic")

    def __init__(self, topic: str, schema: Schema, data: bytes | Callable[[], bytes],
                 t: float, seq: int = 0):
        self.topic, self.schema, self.t, self.seq = topic, schema, t, seq
        self._data: bytes | None = data if isinstance(data, bytes) else None
        self._make: Callable[[], bytes] | None = None if isinstance(data, bytes) else data

    @property
    def data(self) -> bytes:
        if self._data is None:
            assert self._make is not None
            self._data, self._make = self._make(), None
        return self._data


def json_schema(title: str, properties: dict[str, object], required: list[str] | None = None,
                extra: object = None) -> Schema:
    s: dict[str, object] = {"type": "object", "title": title, "properties": properties}
    if required:
        s["required"] = required
    if extra is not None:
        s["additionalProperties"] = extra
    return Schema(title, "jsonschema", json.dumps(s).encode())


def native(name: str) -> Schema:
    return Schema(name, "protobuf", fp.schema_bytes(name))


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
LOG, POSE, TF = native("foxglove.Log"), native("foxglove.PoseInFrame"), native("foxglove.FrameTransform")
IMAGE, SCENE = native("foxglove.CompressedImage"), native("foxglove.SceneUpdate")
LATCH = json_schema("esair.Latch", {
    "seq": {"type": "integer", "description": "the state's number, from 1"},
    "t": {"type": "number", "description": "seconds since the epoch: the STOP or the release"},
    "stopped": {"type": "boolean"},
    "by": {"type": "string", "description": "who STOPPED it"},
    "reason": {"type": "string"},
    "released_by": {"type": "string", "description": "who released it"}},
    ["seq", "t", "stopped"])


def levels_schema(n: int) -> Schema:
    return json_schema(f"esair.MicLevels{n}", {
        f"mic{i}": {"type": "number", "description": "RMS level of the frame, full scale = 1"}
        for i in range(n)}, [f"mic{i}" for i in range(n)])


def _js(obj: object) -> bytes:
    return json.dumps(obj, separators=(",", ":")).encode()


def _yaw(th: float) -> bytes:
    return fp.quaternion(0.0, 0.0, math.sin(th / 2), math.cos(th / 2))


def _color(rgb: object, a: float = 1.0) -> bytes:
    r, g, b = (list(rgb) + [128, 128, 128])[:3] if isinstance(rgb, list) else (128, 128, 128)
    return fp.color(r / 255, g / 255, b / 255, a)


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
        return Out(LOG_TOPIC, LOG, lambda: fp.log(t, fp.LOG_LEVELS.get(level, 2), text, name), t)

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
        out = [Out(COMMAND_TOPIC + actuator, COMMAND, lambda: _js(dict(rec, seq=seq, t=t)), t, seq)]
        cmd = rec.get("command")
        if "ok" in rec and ".servo." in actuator and isinstance(cmd, dict) and _num(cmd.get("angle")):
            entry, joint = actuator.split(".servo.", 1)
            joints = self.joints.setdefault(entry, {})
            if joints.get(joint) != cmd["angle"]:
                joints[joint] = float(cmd["angle"])
                now = dict(joints, t=t)
                out.append(Out(f"/{entry}/joints", JOINTS, lambda: _js(now), t))
        return out

    def sample(self, sensor: str, seq: int, t: float, v: object) -> list[Out]:
        schema = self.schemas.get(sensor)
        if schema is None:
            schema = self.schemas[sensor] = sample_schema(sensor, v)
        out = [Out(sensor, schema, lambda: _js({"seq": seq, "t": t, "value": v}), t, seq)]
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
        bearing = float(last["bearing"])

        def make() -> bytes:
            arrow = fp.arrow(fp.pose(fp.vector3(0.0, 0.0, 0.1), _yaw(bearing)), 0.8, 0.03, 0.15,
                             0.08, fp.color(1.0, 0.3, 0.1, 1.0))
            return fp.scene_update([fp.scene_entity(t, "base_link", f"bearing:{behavior}",
                                                    frame_locked=True, arrows=[arrow])])
        return [Out(f"/{entry}/scene", SCENE, make, t) for entry in self.room]

    # ---- the native shapes
    def _picture(self, entry: str, t: float, v: dict) -> list[Out]:
        """The picture's own bytes (JPEG/PNG, not decoded) in a CompressedImage."""
        ts = float(v["t"]) if _num(v.get("t")) else t
        image, fmt = v["image"], str(v["format"])

        def make() -> bytes:
            try:
                data = base64.b64decode(image, validate=True)
            except (binascii.Error, ValueError):
                data = b""                       # a bad sample: an empty image
            return fp.compressed_image(ts, "camera", data, fmt)
        return [Out(f"/{entry}/camera", IMAGE, make, t)]

    def _pose(self, entry: str, t: float, v: dict) -> list[Out]:
        x, y, th = float(v["x"]), float(v["y"]), float(v["th"])
        return [Out(f"/{entry}/pose", POSE, lambda: fp.pose_in_frame(
                    t, "world", fp.pose(fp.vector3(x, y, 0.0), _yaw(th))), t),
                Out(TF_TOPIC, TF, lambda: fp.frame_transform(
                    t, "world", "base_link", fp.vector3(x, y, 0.0), _yaw(th)), t)]

    def _scene(self, entry: str, t: float, v: dict) -> Out:
        return Out(f"/{entry}/scene", SCENE, lambda: _room(t, v), t)

    def _levels(self, sensor: str, t: float, v: dict) -> list[Out]:
        n = v["channels"]
        if n <= 0:
            return []
        pcm = v["pcm"]
        return [Out(f"/{sensor.replace('.', '/')}/levels", levels_schema(n),
                    lambda: _js(_rms(pcm, n)), t)]


def _rms(pcm64: str, n: int) -> dict[str, float]:
    """The RMS level of each channel of one frame of interleaved little-endian 16-bit
    PCM, full scale = 1 (math.hypot: the square root of the sum of squares in C; no
    numpy: it would add ~14 MB to the live server's RSS); a bad frame: zeros."""
    try:
        pcm = array("h", base64.b64decode(pcm64))
    except (binascii.Error, ValueError):
        pcm = array("h")
    if sys.byteorder == "big":
        pcm.byteswap()
    frames = len(pcm) // n
    return {f"mic{i}": round(math.hypot(*pcm[i:frames * n:n]) / math.sqrt(frames) / 32768, 6)
            if frames else 0.0 for i in range(n)}


def _room(t: float, v: dict) -> bytes:
    """A map sample as the scene's entity ``room``: walls as lines, poles as cylinders,
    the access point and the sound source (when on) as spheres."""
    points = [fp.point3(float(x), float(y), 0.0) for w in v["walls"]
              if isinstance(w, list) and len(w) == 4 for x, y in ((w[0], w[1]), (w[2], w[3]))]
    walls = [fp.line_list(0.05, points, fp.color(0.8, 0.8, 0.8, 1.0))]
    cylinders, spheres = [], []
    for lm in v["landmarks"]:
        if not isinstance(lm, dict) or not (_num(lm.get("x")) and _num(lm.get("y"))):
            continue
        at = fp.pose(fp.vector3(float(lm["x"]), float(lm["y"]), 0.25), _yaw(0.0))
        kind = lm.get("kind")
        if kind == "pole":
            d = 2 * float(lm.get("r", 0.1))
            cylinders.append(fp.cylinder(at, fp.vector3(d, d, 0.5), 1.0, 1.0,
                                         _color(lm.get("color"))))
        elif kind == "access_point":
            spheres.append(fp.sphere(at, fp.vector3(0.2, 0.2, 0.2), fp.color(0.2, 0.6, 1.0, 1.0)))
        elif kind == "sound" and lm.get("on", True):
            spheres.append(fp.sphere(at, fp.vector3(0.25, 0.25, 0.25),
                                     fp.color(1.0, 0.2, 0.2, 1.0)))
    return fp.scene_update([fp.scene_entity(t, "world", "room", lines=walls,
                                            cylinders=cylinders, spheres=spheres)])
