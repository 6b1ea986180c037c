"""STARFISH's microphone array: 4 channels, 16 kHz, 16-bit, frames of 1024 samples with
sequence numbers — and, in simulation, the audio those microphones hear in the room.

:class:`AudioRenderer` renders each frame from the room and the robot's pose: the
source emits a continuous band-limited noise (a Kaiser-windowed FIR band-pass, numpy, over
a seeded Gaussian stream, its tail kept from frame to frame); each microphone, at its
own position on the robot, hears that stream

- delayed by its distance to the source over the speed of sound — a fractional delay:
  the integer part by indexing the source's history, the fraction by a Kaiser-windowed
  sinc kernel (numpy.convolve);
- attenuated as 1/distance (spherical spreading; ``level`` is the RMS at 1 m);
- plus independent white noise per channel at the configured SNR, defined at the
  array's centre against the direct sound's RMS there (the noise stays when the source is
  silent, so a listener hears the room's noise floor);

- with ``reflection_gain`` > 0, also the first-order echoes off every wall (image
  sources: the source mirrored across the wall's line, heard where the mirrored path
  meets the wall segment and both ends are on the wall's same side), each scaled by
  that gain and 1/path length — the reverberation that makes GCC-PHAT earn its keep;

then quantised to int16 (clipped samples are counted). Walls do not occlude sound, and
echoes of echoes are not rendered.

A frame on the wire is JSON (:func:`encode_frame`): ``seq``, ``n0`` (index of its first
sample in the stream), ``rate``, ``channels``, ``n``, ``mics`` (the microphones'
positions on the robot, metres, robot frame), ``t`` (time.time() when rendered) and
``pcm``: base64 of the interleaved little-endian int16 samples.
"""

from __future__ import annotations

import base64
import math
from typing import TYPE_CHECKING, Sequence

import numpy as np

from .scene import Scene

if TYPE_CHECKING:  # pragma: no cover
    from ...transport.codec import JSONObject

RATE = 16000
FRAME = 1024
CHANNELS = 4
SPEED_OF_SOUND = 343.0
# the robot's array: four microphones on a square, 0.12 m from the centre, at 45, 135,
# 225 and 315 degrees (robot frame: x ahead, y to the left)
DEFAULT_MICS = tuple((round(0.12 * math.cos(math.radians(a)), 6),
                      round(0.12 * math.sin(math.radians(a)), 6)) for a in (45, 135, 225, 315))
KERNEL_HALF = 24                    # the fractional-delay kernel: 2*24+1 taps
BAND_HZ = (300.0, 5000.0)           # the source's band
BAND_TAPS = 129                     # its FIR band-pass (numpy only: the robot's driver
                                    # process does not load scipy.signal, ~78 MB of RSS)


class FrameError(ValueError):
    """A microphone frame that cannot be decoded (the message says why)."""


_TAPS = np.arange(-KERNEL_HALF, KERNEL_HALF + 1)
_WINDOW = np.kaiser(2 * KERNEL_HALF + 1, 8.0)     # computed once: each frame's 4+ kernels use it


def _fractional_kernel(frac: float, half: int = KERNEL_HALF) -> np.ndarray:
    """Taps h[k], k = -half..half, delaying a signal by ``frac`` (0 <= frac < 1) samples."""
    taps: np.ndarray
    if half == KERNEL_HALF:
        taps = np.sinc(_TAPS - frac) * _WINDOW
    else:
        k = np.arange(-half, half + 1)
        taps = np.sinc(k - frac) * np.kaiser(2 * half + 1, 8.0)
    return taps


class AudioRenderer:
    """Renders the array's frames from a room, frame after frame (one continuous
    stream). ``render(pose)`` returns the next frame as an int16 array (n, channels)."""

    def __init__(self, room: Scene, mics: Sequence[Sequence[float]] = DEFAULT_MICS,
                 rate: int = RATE, frame: int = FRAME, snr_db: float = 20.0, seed: int = 0,
                 speed_of_sound: float = SPEED_OF_SOUND, reflection_gain: float = 0.0):
        self.room = room
        if not 0.0 <= reflection_gain < 1.0:
            raise ValueError(f"reflection_gain must be in [0, 1), not {reflection_gain!r}")
        self.reflection_gain = float(reflection_gain)
        self.mics = np.asarray(mics, dtype=float)
        if self.mics.ndim != 2 or self.mics.shape[1] != 2 or len(self.mics) < 2:
            raise ValueError("mics must be a list of at least two [x, y] positions")
        self.rate, self.frame, self.c = int(rate), int(frame), float(speed_of_sound)
        self.snr_db = float(snr_db)
        self.rng = np.random.default_rng(seed)
        n = np.arange(BAND_TAPS) - (BAND_TAPS - 1) / 2
        lo, hi = BAND_HZ[0] / self.rate, BAND_HZ[1] / self.rate
        self.band = (2 * hi * np.sinc(2 * hi * n) - 2 * lo * np.sinc(2 * lo * n)) * np.kaiser(BAND_TAPS, 8.0)
        self.unit_rms = float(np.sqrt(np.sum(self.band ** 2)))    # white in -> band RMS
        self.white_tail = np.zeros(BAND_TAPS - 1)
        # the source's history: enough for the longest delay the room allows
        x0, y0, x1, y1 = room.bounds()
        self.max_delay = int(math.ceil(math.hypot(x1 - x0, y1 - y0) * 3.0 * self.rate / self.c))
        self.hist_len = self.max_delay + 2 * KERNEL_HALF + 2 + self.frame
        self.history = np.zeros(self.hist_len)
        self.n0 = 0                 # index of the next frame's first sample
        self.seq = 0
        self.clipped = 0

    def _emit(self) -> None:
        """Append the source's next ``frame`` samples to the history."""
        white = np.concatenate([self.white_tail, self.rng.standard_normal(self.frame)])
        self.white_tail = white[-(BAND_TAPS - 1):]
        band = np.convolve(white, self.band, mode="valid") / self.unit_rms
        if not self.room.source.on:
            band = np.zeros(self.frame)
        self.history = np.concatenate([self.history[self.frame:], band])

    def _paths(self, mic: np.ndarray, src: tuple[float, float]) -> list[tuple[float, float]]:
        """(length, gain) of the direct path and of each first-order echo."""
        s = np.asarray(src, dtype=float)
        paths = [(max(float(np.hypot(*(mic - s))), 0.05), 1.0)]
        if self.reflection_gain <= 0:
            return paths
        a, b = self.room.a, self.room.b
        e = b - a
        n = np.stack([-e[:, 1], e[:, 0]], axis=1) / np.hypot(e[:, 0], e[:, 1])[:, None]
        side_s = ((s - a) * n).sum(axis=1)
        side_m = ((mic - a) * n).sum(axis=1)
        image = s[None, :] - 2 * side_s[:, None] * n                      # (walls, 2)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = side_m / (side_m - (-side_s))        # where mic -> image crosses the line
            meet = mic[None, :] + t[:, None] * (image - mic[None, :])
            u = ((meet - a) * e).sum(axis=1) / (e * e).sum(axis=1)
        ok = (side_s * side_m > 0) & (u >= 0) & (u <= 1)
        for w in np.nonzero(ok)[0]:
            paths.append((float(np.hypot(*(mic - image[w]))), self.reflection_gain))
        return paths

    def _add_path(self, out: np.ndarray, dist: float, amplitude: float) -> None:
        """Add the source's stream heard over a path of ``dist`` metres to ``out``."""
        d = dist * self.rate / self.c
        if d > self.max_delay:
            return
        whole = int(math.floor(d))
        kern = _fractional_kernel(d - whole)
        # the frame ends KERNEL_HALF samples before the newest source sample, so that the
        # kernel of the nearest microphone has its future half in the history too;
        # y[j] = sum_k h[k] s[j - whole - k]: the slice that the 'valid' convolution needs
        stop = self.hist_len - whole
        start = stop - self.frame - 2 * KERNEL_HALF
        out += np.convolve(self.history[start:stop], kern, mode="valid") * amplitude

    def render(self, pose: Sequence[float]) -> np.ndarray:
        """The next frame heard at ``pose`` (x, y, theta): int16 array (frame, channels)."""
        self._emit()
        x, y, th = (float(v) for v in pose)
        c, s = math.cos(th), math.sin(th)
        world = np.stack([x + c * self.mics[:, 0] - s * self.mics[:, 1],
                          y + s * self.mics[:, 0] + c * self.mics[:, 1]], axis=1)
        src = self.room.source
        level = src.level
        out = np.zeros((self.frame, len(self.mics)))
        for i in range(len(self.mics)):
            for dist, gain in self._paths(world[i], (src.x, src.y)):
                self._add_path(out[:, i], dist, gain * level / dist)
        centre = max(math.hypot(x - src.x, y - src.y), 0.05)
        noise_rms = (level / centre) / (10.0 ** (self.snr_db / 20.0))
        out += self.rng.standard_normal(out.shape) * noise_rms
        scaled = np.round(out * 32767.0)
        over = np.abs(scaled) > 32767
        self.clipped += int(over.sum())
        pcm = np.clip(scaled, -32768, 32767).astype(np.int16)
        self.n0 += self.frame
        self.seq += 1
        return pcm


def encode_frame(pcm: np.ndarray, seq: int, n0: int, mics: Sequence[Sequence[float]],
                 t: float, rate: int = RATE) -> JSONObject:
    """One frame as the JSON object a sensor reports."""
    data = np.ascontiguousarray(pcm, dtype="<i2")
    return {"seq": int(seq), "n0": int(n0), "rate": int(rate), "channels": int(data.shape[1]),
            "n": int(data.shape[0]), "mics": [[float(a), float(b)] for a, b in mics],
            "t": float(t), "pcm": base64.b64encode(data.tobytes()).decode("ascii")}


def decode_frame(frame: object) -> tuple[np.ndarray, np.ndarray, int]:
    """(samples as float in [-1, 1), shape (n, channels); mic positions (channels, 2);
    rate) from a frame object; FrameError on anything malformed."""
    if not isinstance(frame, dict):
        raise FrameError(f"a frame must be an object, not {type(frame).__name__}")
    for key in ("rate", "channels", "n", "mics", "pcm"):
        if key not in frame:
            raise FrameError(f"frame has no {key!r}")
    rate, ch, n = frame["rate"], frame["channels"], frame["n"]
    for key, v in (("rate", rate), ("channels", ch), ("n", n)):
        if not isinstance(v, int) or isinstance(v, bool) or v <= 0:
            raise FrameError(f"frame's {key!r} must be a positive integer, not {v!r}")
    try:
        raw = base64.b64decode(frame["pcm"], validate=True)
    except (ValueError, TypeError):
        raise FrameError("frame's 'pcm' is not base64") from None
    if len(raw) != 2 * ch * n:
        raise FrameError(f"frame's 'pcm' holds {len(raw)} bytes, not {2 * ch * n} "
                         f"({n} samples x {ch} channels x 2)")
    try:
        mics = np.asarray(frame["mics"], dtype=float)
    except (ValueError, TypeError):
        raise FrameError("frame's 'mics' must be a list of [x, y]") from None
    if mics.shape != (ch, 2) or not np.isfinite(mics).all():
        raise FrameError(f"frame's 'mics' must hold {ch} [x, y] positions")
    pcm = np.frombuffer(raw, dtype="<i2").reshape(n, ch).astype(float) / 32768.0
    return pcm, mics, rate
