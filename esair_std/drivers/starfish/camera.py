"""STARFISH's camera in simulation: a picture of the room as seen from the robot's pose.

A pinhole camera at ``height`` above the floor looks along the robot's heading with a
horizontal field of view ``fov_deg``; each of the image's columns casts one ray into
the room (room.Room.cast, vectorised over the columns). What a ray meets is drawn as a
vertical span projected by its distance along the optical axis (no fish-eye): the wall
(shaded by its direction and distance), and in front of it, farthest first, the
landmarks (coloured cylinders) and the sound source (a red cylinder, the marker). Floor
and ceiling are flat colours. The image (numpy, uint8 RGB) is encoded by Pillow, PNG by
default (JPEG on request).
"""

from __future__ import annotations

import io
import math
from typing import Sequence

import numpy as np
from PIL import Image

from .scene import SOURCE_COLOR, SOURCE_HEIGHT, SOURCE_RADIUS, Scene

WIDTH, HEIGHT = 320, 240
FOV_DEG = 60.0
CAMERA_HEIGHT = 0.3
SKY = (200, 200, 205)
FLOOR = (120, 105, 90)
WALL = np.array([225, 220, 200], dtype=float)


def _cylinder_hits(origin: np.ndarray, dirs: np.ndarray, cx: float, cy: float,
                   r: float) -> np.ndarray:
    """Distance along each unit ray to a vertical cylinder (inf where it misses)."""
    oc = origin - np.array([cx, cy])
    b = dirs @ oc
    c = float(oc @ oc) - r * r
    disc = b * b - c
    with np.errstate(invalid="ignore"):
        t = -b - np.sqrt(disc)
    return np.where((disc >= 0) & (t > 0), t, np.inf)


class Camera:
    """Renders pictures of ``room``; ``render(pose)`` -> uint8 array (height, width, 3)."""

    def __init__(self, room: Scene, width: int = WIDTH, height: int = HEIGHT,
                 fov_deg: float = FOV_DEG, camera_height: float = CAMERA_HEIGHT):
        if not (16 <= width <= 4096 and 16 <= height <= 4096):
            raise ValueError(f"picture size {width}x{height} is outside 16..4096")
        if not 10 <= fov_deg <= 170:
            raise ValueError(f"field of view {fov_deg} deg is outside 10..170")
        self.room, self.width, self.height = room, int(width), int(height)
        self.camera_height = float(camera_height)
        self.focal = (self.width / 2.0) / math.tan(math.radians(fov_deg) / 2.0)
        # each column's angle off the optical axis (positive: to the left)
        cols = np.arange(self.width) + 0.5
        self.offsets = np.arctan((self.width / 2.0 - cols) / self.focal)

    def column_of(self, bearing: float) -> float:
        """The image column (0 = left edge) where a point at ``bearing`` (robot frame,
        radians, positive to the left) appears."""
        return self.width / 2.0 - self.focal * math.tan(bearing)

    def _span(self, depth: np.ndarray, z0: float, z1: float) -> tuple[np.ndarray, np.ndarray]:
        """Rows (top, bottom) of a vertical span z0..z1 at each column's depth."""
        cy = self.height / 2.0
        with np.errstate(divide="ignore", invalid="ignore"):
            top = cy - self.focal * (z1 - self.camera_height) / depth
            bottom = cy - self.focal * (z0 - self.camera_height) / depth
        top = np.clip(np.nan_to_num(top, nan=cy, posinf=cy, neginf=0), 0, self.height)
        bottom = np.clip(np.nan_to_num(bottom, nan=cy, posinf=self.height, neginf=cy), 0, self.height)
        return top.astype(int), bottom.astype(int)

    def render(self, pose: Sequence[float]) -> np.ndarray:
        x, y, th = (float(v) for v in pose)
        img = np.empty((self.height, self.width, 3), dtype=np.uint8)
        img[: self.height // 2] = SKY
        img[self.height // 2:] = FLOOR
        angles = th + self.offsets
        origin = np.array([x, y])
        dirs = np.stack([np.cos(angles), np.sin(angles)], axis=1)
        cosoff = np.cos(self.offsets)
        rows = np.arange(self.height)[:, None]
        dist, wall = self.room.cast((x, y), angles)
        # walls: lighter when seen square-on, darker with distance
        e = self.room.b - self.room.a
        normal = np.stack([-e[:, 1], e[:, 0]], axis=1) / np.hypot(e[:, 0], e[:, 1])[:, None]
        facing = np.abs((normal[np.maximum(wall, 0)] * dirs).sum(axis=1))
        shade = (0.55 + 0.45 * facing) * np.clip(1.1 - dist / 12.0, 0.5, 1.0)
        colour = np.clip(WALL[None, :] * shade[:, None], 0, 255).astype(np.uint8)
        self._paint(img, rows, dist * cosoff, np.isfinite(dist), 0.0, self.room.wall_height, colour)
        # objects in front of the wall, farthest first
        objects = [(lm["x"], lm["y"], lm["r"], lm["height"], lm["color"]) for lm in self.room.landmarks]
        src = self.room.source
        objects.append((src.x, src.y, SOURCE_RADIUS, SOURCE_HEIGHT, SOURCE_COLOR))
        objects.sort(key=lambda o: -math.hypot(o[0] - x, o[1] - y))
        for ox, oy, r, h, col in objects:
            t = _cylinder_hits(origin, dirs, ox, oy, r)
            seen = np.isfinite(t) & (t < dist)
            if seen.any():
                colour = np.broadcast_to(np.asarray(col, dtype=np.uint8), (self.width, 3))
                self._paint(img, rows, t * cosoff, seen, 0.0, h, colour)
        return img

    def _paint(self, img: np.ndarray, rows: np.ndarray, depth: np.ndarray, mask: np.ndarray,
               z0: float, z1: float, colour: np.ndarray) -> None:
        top, bottom = self._span(np.where(mask, depth, np.inf), z0, z1)
        inside = (rows >= top[None, :]) & (rows < bottom[None, :]) & mask[None, :]
        img[inside] = np.broadcast_to(colour[None, :, :], img.shape)[inside]


def encode(img: np.ndarray, fmt: str = "png", quality: int = 85) -> bytes:
    """The picture as PNG or JPEG bytes (Pillow)."""
    fmt = fmt.lower()
    if fmt not in ("png", "jpeg"):
        raise ValueError(f"picture format must be 'png' or 'jpeg', not {fmt!r}")
    buf = io.BytesIO()
    if fmt == "png":
        Image.fromarray(img, "RGB").save(buf, format="PNG", optimize=False)
    else:
        Image.fromarray(img, "RGB").save(buf, format="JPEG", quality=int(quality))
    return buf.getvalue()


def decode(data: bytes) -> np.ndarray:
    """PNG or JPEG bytes back to a uint8 RGB array (for tests and the remote center)."""
    with Image.open(io.BytesIO(data)) as im:
        return np.asarray(im.convert("RGB"))


def marker_columns(img: np.ndarray, colour: Sequence[int] = SOURCE_COLOR, tol: int = 30) -> np.ndarray:
    """The columns where the marker's colour shows (empty if it does not)."""
    diff = np.abs(img.astype(int) - np.asarray(colour)[None, None, :]).max(axis=2)
    return np.nonzero((diff <= tol).any(axis=0))[0]
