"""The few Foxglove messages ESAIR sends (docs/foxglove.md), encoded as protobuf by hand:
the wire format of Foxglove's .proto definitions (field numbers of the schemas in
foxschemas.py, fields in their numbers' order; proto3: a scalar at its default is left out), so
neither the recorder nor the live server imports foxglove-sdk (~8 MB of RSS) or a
protobuf runtime. tests/std/test_foxproto.py checks each against the SDK's encoder,
byte for byte.

Each function returns a message's bytes; a nested message is passed as its bytes."""

from __future__ import annotations

import base64
import struct
from collections.abc import Iterable

from .foxschemas import SCHEMAS

_D = struct.Struct("<d")
_BYTE = [bytes((i,)) for i in range(0x80)]

# foxglove.Log.Level, foxglove.LinePrimitive.Type
LOG_LEVELS = {"debug": 1, "info": 2, "warning": 3, "error": 4, "fatal": 5}
LINE_LIST = 2


def schema_bytes(name: str) -> bytes:
    """The FileDescriptorSet of ``foxglove.<Name>``."""
    return base64.b64decode("".join(SCHEMAS[name]))


def _varint(n: int) -> bytes:
    if 0 <= n < 0x80:
        return _BYTE[n]
    if n < 0:
        n += 1 << 64                       # int64 / enum: two's complement, 10 bytes
    out = bytearray()
    while n > 0x7F:
        out.append(n & 0x7F | 0x80)
        n >>= 7
    out.append(n)
    return bytes(out)


def _double(field: int, v: float) -> bytes:
    return bytes((field << 3 | 1,)) + _D.pack(v) if v else b""


def _int(field: int, v: int) -> bytes:
    return bytes((field << 3,)) + _varint(v) if v else b""


def _len(field: int, data: bytes) -> bytes:
    return _varint(field << 3 | 2) + _varint(len(data)) + data


def _str(field: int, s: str) -> bytes:
    return _len(field, s.encode()) if s else b""


def _many(field: int, items: Iterable[bytes]) -> bytes:
    return b"".join(_len(field, m) for m in items)


def timestamp(t: float) -> bytes:
    """google.protobuf.Timestamp of seconds since the epoch."""
    sec = int(t)
    return _int(1, sec) + _int(2, min(999_999_999, int((t - sec) * 1e9)))


def vector3(x: float, y: float, z: float) -> bytes:
    return _double(1, x) + _double(2, y) + _double(3, z)


point3 = vector3


def quaternion(x: float, y: float, z: float, w: float) -> bytes:
    return _double(1, x) + _double(2, y) + _double(3, z) + _double(4, w)


def color(r: float, g: float, b: float, a: float) -> bytes:
    return quaternion(r, g, b, a)          # the same four doubles, 1..4


def pose(position: bytes, orientation: bytes) -> bytes:
    return _len(1, position) + _len(2, orientation)


def log(t: float, level: int, message: str, name: str) -> bytes:
    return _len(1, timestamp(t)) + _int(2, level) + _str(3, message) + _str(4, name)


def pose_in_frame(t: float, frame_id: str, the_pose: bytes) -> bytes:
    return _len(1, timestamp(t)) + _str(2, frame_id) + _len(3, the_pose)


def frame_transform(t: float, parent: str, child: str, translation: bytes,
                    rotation: bytes) -> bytes:
    return (_len(1, timestamp(t)) + _str(2, parent) + _str(3, child) + _len(4, translation)
            + _len(5, rotation))


def compressed_image(t: float, frame_id: str, data: bytes, fmt: str) -> bytes:
    return _len(1, timestamp(t)) + _len(2, data) + _str(3, fmt) + _str(4, frame_id)


def arrow(the_pose: bytes, shaft_length: float, shaft_diameter: float, head_length: float,
          head_diameter: float, the_color: bytes) -> bytes:
    return (_len(1, the_pose) + _double(2, shaft_length) + _double(3, shaft_diameter)
            + _double(4, head_length) + _double(5, head_diameter) + _len(6, the_color))


def cylinder(the_pose: bytes, size: bytes, bottom_scale: float, top_scale: float,
             the_color: bytes) -> bytes:
    return (_len(1, the_pose) + _len(2, size) + _double(3, bottom_scale)
            + _double(4, top_scale) + _len(5, the_color))


def sphere(the_pose: bytes, size: bytes, the_color: bytes) -> bytes:
    return _len(1, the_pose) + _len(2, size) + _len(3, the_color)


def line_list(thickness: float, points: list[bytes], the_color: bytes) -> bytes:
    """A LinePrimitive of type LINE_LIST, not scale invariant."""
    return _int(1, LINE_LIST) + _double(3, thickness) + _many(5, points) + _len(6, the_color)


def scene_entity(t: float, frame_id: str, eid: str, frame_locked: bool = False,
                 arrows: Iterable[bytes] = (), spheres: Iterable[bytes] = (),
                 cylinders: Iterable[bytes] = (), lines: Iterable[bytes] = ()) -> bytes:
    return (_len(1, timestamp(t)) + _str(2, frame_id) + _str(3, eid)
            + _int(5, int(frame_locked)) + _many(7, arrows) + _many(9, spheres)
            + _many(10, cylinders) + _many(11, lines))


def scene_update(entities: Iterable[bytes]) -> bytes:
    return _many(2, entities)
