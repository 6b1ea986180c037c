"""The Foxglove messages ESAIR encodes by hand (esair_std/record/foxproto.py) and the
schemas it ships (foxschemas.py) are foxglove-sdk's, byte for byte: each message built
both ways from the same values (negative, zero and fractional ones: proto3 leaves a
zero out, an int64 below zero takes ten bytes), and scripts/foxglove_schemas.py would
write foxschemas.py as it is."""

from __future__ import annotations

import math

import pytest
from foxglove import messages as fm

from esair_std.record import foxproto as fp
from esair_std.record.foxmsgs import Converter
from scripts.foxglove_schemas import OUT, text

T = 1764369012.123456789
TIMES = [T, 0.0, 1.5]


def stamp(t: float) -> fm.Timestamp:
    sec = int(t)
    return fm.Timestamp(sec=sec, nsec=min(999_999_999, int((t - sec) * 1e9)))


def yaw(th: float) -> fm.Quaternion:
    return fm.Quaternion(x=0.0, y=0.0, z=math.sin(th / 2), w=math.cos(th / 2))


def test_the_shipped_schemas_are_the_sdks():
    assert OUT.read_text() == text()
    for name in ("Log", "PoseInFrame", "FrameTransform", "CompressedImage", "SceneUpdate"):
        assert fp.schema_bytes(f"foxglove.{name}") == bytes(getattr(fm, name).get_schema().data)


@pytest.mark.parametrize("t", TIMES)
def test_log_pose_transform_and_image_are_the_sdks(t):
    assert fp.log(t, 3, "wheels: ready -> lost", "starfish.wheels") == fm.Log(
        timestamp=stamp(t), level=fm.LogLevel.Warning, message="wheels: ready -> lost",
        name="starfish.wheels", file="", line=0).encode()
    assert fp.log(t, 2, "", "") == fm.Log(timestamp=stamp(t), level=fm.LogLevel.Info).encode()
    for x, y, th in ((1.25, -3.5, 2.0), (0.0, 0.0, 0.0), (-0.001, 7.0, -3.1)):
        assert fp.pose_in_frame(t, "world", fp.pose(fp.vector3(x, y, 0.0), fp.quaternion(
            0.0, 0.0, math.sin(th / 2), math.cos(th / 2)))) == fm.PoseInFrame(
            timestamp=stamp(t), frame_id="world",
            pose=fm.Pose(position=fm.Vector3(x=x, y=y, z=0.0), orientation=yaw(th))).encode()
        assert fp.frame_transform(t, "world", "base_link", fp.vector3(x, y, 0.0), fp.quaternion(
            0.0, 0.0, math.sin(th / 2), math.cos(th / 2))) == fm.FrameTransform(
            timestamp=stamp(t), parent_frame_id="world", child_frame_id="base_link",
            translation=fm.Vector3(x=x, y=y, z=0.0), rotation=yaw(th)).encode()
    png = bytes(range(256)) * 300
    assert fp.compressed_image(t, "camera", png, "png") == fm.CompressedImage(
        timestamp=stamp(t), frame_id="camera", data=png, format="png").encode()


def test_the_room_and_the_bearing_are_the_sdks():
    room = {"walls": [[0, 0, 4, 0], [4, 0, 4, -3.5], "not a wall"],
            "landmarks": [{"kind": "pole", "x": 1, "y": 2, "r": 0.15, "color": [255, 0, 10]},
                          {"kind": "pole", "x": -1, "y": 0},
                          {"kind": "access_point", "x": 0.5, "y": 3.0},
                          {"kind": "sound", "x": 1.0, "y": 3.5, "on": True},
                          {"kind": "sound", "x": 2.0, "y": 3.5, "on": False}]}
    conv = Converter()
    got = {o.topic: o.data for o in conv.sample("starfish.map", 3, T, room)}
    q0 = yaw(0.0)
    walls = fm.LinePrimitive(type=fm.LinePrimitiveLineType.LineList, thickness=0.05,
                             scale_invariant=False, color=fm.Color(r=0.8, g=0.8, b=0.8, a=1.0),
                             points=[fm.Point3(x=float(x), y=float(y), z=0.0)
                                     for x, y in ((0, 0), (4, 0), (4, 0), (4, -3.5))])

    def at(x, y):
        return fm.Pose(position=fm.Vector3(x=float(x), y=float(y), z=0.25), orientation=q0)
    cylinders = [fm.CylinderPrimitive(pose=at(1, 2), size=fm.Vector3(x=0.3, y=0.3, z=0.5),
                                      bottom_scale=1.0, top_scale=1.0,
                                      color=fm.Color(r=1.0, g=0.0, b=10 / 255, a=1.0)),
                 fm.CylinderPrimitive(pose=at(-1, 0), size=fm.Vector3(x=0.2, y=0.2, z=0.5),
                                      bottom_scale=1.0, top_scale=1.0,
                                      color=fm.Color(r=128 / 255, g=128 / 255, b=128 / 255, a=1.0))]
    spheres = [fm.SpherePrimitive(pose=at(0.5, 3.0), size=fm.Vector3(x=0.2, y=0.2, z=0.2),
                                  color=fm.Color(r=0.2, g=0.6, b=1.0, a=1.0)),
               fm.SpherePrimitive(pose=at(1.0, 3.5), size=fm.Vector3(x=0.25, y=0.25, z=0.25),
                                  color=fm.Color(r=1.0, g=0.2, b=0.2, a=1.0))]
    ent = fm.SceneEntity(timestamp=stamp(T), frame_id="world", id="room", lines=[walls],
                         cylinders=cylinders, spheres=spheres)
    assert got["/starfish/scene"] == fm.SceneUpdate(entities=[ent]).encode()

    (bearing,) = conv.state("localize", {"last": {"bearing": -0.7, "t": T}})
    arrow = fm.ArrowPrimitive(pose=fm.Pose(position=fm.Vector3(x=0.0, y=0.0, z=0.1),
                                           orientation=yaw(-0.7)),
                              shaft_length=0.8, shaft_diameter=0.03, head_length=0.15,
                              head_diameter=0.08, color=fm.Color(r=1.0, g=0.3, b=0.1, a=1.0))
    ent = fm.SceneEntity(timestamp=stamp(T), frame_id="base_link", id="bearing:localize",
                         frame_locked=True, arrows=[arrow])
    assert bearing.data == fm.SceneUpdate(entities=[ent]).encode()


def test_the_microphones_levels_are_their_rms():
    import base64

    import numpy as np
    rng = np.random.default_rng(3)
    pcm = (rng.normal(0, [1000, 8000, 50, 20000], (480, 4))).clip(-32768, 32767).astype("<i2")
    (out,) = Converter().sample("starfish.mics", 1, T, {"channels": 4, "rate": 16000,
                                                         "pcm": base64.b64encode(pcm.tobytes()).decode()})[1:]
    want = np.sqrt((pcm.astype(float) ** 2).mean(axis=0)) / 32768
    got = __import__("json").loads(out.data)
    assert out.topic == "/starfish/mics/levels"
    assert [got[f"mic{i}"] for i in range(4)] == pytest.approx(want, abs=1e-6)


@pytest.mark.parametrize("n", [0, 125, 126, 65535, 65536, 200_000])
def test_the_live_servers_websocket_frames_are_websockets_own(n):
    """foxserver writes its frames' headers itself: as websockets serializes them."""
    from websockets.frames import Frame, Opcode

    from esair_std.record.foxserver import _ws_frame
    data = bytes(range(256)) * (n // 256) + bytes(n % 256)
    assert _ws_frame(data) == Frame(Opcode.BINARY, data).serialize(mask=False)
    text = "é" * (n // 2)
    assert _ws_frame(text) == Frame(Opcode.TEXT, text.encode()).serialize(mask=False)
