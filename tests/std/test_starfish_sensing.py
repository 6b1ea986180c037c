"""STARFISH's simulated microphone array, GCC-PHAT localization and camera, on rendered
audio and pictures (esair_std/drivers/starfish/)."""

import math

import numpy as np
import pytest

from esair_std.drivers.starfish import camera as cam
from esair_std.drivers.starfish.gccphat import Localizer, gcc_phat
from esair_std.drivers.starfish.mics import (DEFAULT_MICS, FRAME, RATE, SPEED_OF_SOUND, AudioRenderer,
                                             FrameError, decode_frame, encode_frame)
from esair_std.drivers.starfish.scene import Source, SceneError, bearing_to, wrap
from tests.support.starfish_comps import example_scene


def room_with(x, y, on=True):
    return example_scene((x, y), on)


def angle_error_deg(a, b):
    return abs(math.degrees(wrap(a - b)))


# --- microphone array -----------------------------------------------------------------

def test_frames_are_4_channels_of_1024_int16_numbered_in_one_stream():
    r = AudioRenderer(room_with(5, 3), snr_db=20, seed=3)
    frames = [r.render((1, 1, 0)) for _ in range(3)]
    assert [f.shape for f in frames] == [(FRAME, 4)] * 3 and frames[0].dtype == np.int16
    assert (r.seq, r.n0) == (3, 3 * FRAME)
    obj = encode_frame(frames[2], r.seq, r.n0 - FRAME, DEFAULT_MICS, 12.5)
    assert (obj["seq"], obj["n0"], obj["rate"], obj["channels"], obj["n"]) == (3, 2048, 16000, 4, 1024)
    pcm, mics, rate = decode_frame(obj)
    assert rate == RATE and mics.shape == (4, 2)
    assert np.array_equal(np.round(pcm * 32768).astype(np.int16), frames[2])


def test_each_microphone_hears_the_source_with_its_own_fractional_delay():
    """The lag between two channels' correlation peak (within the source's band) is the difference of the
    microphones' distances to the source over c, to a small part of a sample."""
    src = (3.3, 2.7)
    pose = (1.2, 1.1, 0.4)
    r = AudioRenderer(room_with(*src), snr_db=40, seed=5)
    r.render(pose)
    pcm = r.render(pose).astype(float)
    c, s = math.cos(pose[2]), math.sin(pose[2])
    world = [(pose[0] + c * mx - s * my, pose[1] + s * mx + c * my) for mx, my in DEFAULT_MICS]
    dist = [math.hypot(wx - src[0], wy - src[1]) for wx, wy in world]
    for i, j in [(0, 1), (0, 2), (1, 3), (2, 3)]:
        lags, cc = gcc_phat(pcm[:, i], pcm[:, j], RATE, 0.002, interp=32, band=(400, 4500))
        measured = lags[int(np.argmax(cc))]
        expected = (dist[i] - dist[j]) / SPEED_OF_SOUND
        assert abs(measured - expected) * RATE < 0.1, (i, j, measured * RATE, expected * RATE)


def test_level_falls_as_one_over_distance_and_noise_is_at_the_snr():
    near, far = (1.0, 1.0, 0.0), (4.0, 1.0, 0.0)     # 0.5 m and 3.5 m from the source
    quiet = room_with(0.5, 1.0, on=False)
    loud = room_with(0.5, 1.0, on=True)

    def rms(room, pose, snr):
        r = AudioRenderer(room, snr_db=snr, seed=9)
        return float(np.sqrt(np.mean(np.concatenate([r.render(pose) for _ in range(8)]).astype(float) ** 2)))

    # at 60 dB SNR the noise is negligible: the RMS ratio is the distance ratio
    ratio = rms(loud, near, 60) / rms(loud, far, 60)
    d_near = np.mean([math.hypot(1.0 + mx - 0.5, my) for mx, my in DEFAULT_MICS])
    d_far = np.mean([math.hypot(4.0 + mx - 0.5, my) for mx, my in DEFAULT_MICS])
    assert ratio == pytest.approx(d_far / d_near, rel=0.05)
    # SNR 10 dB at the far pose: signal power / noise power measured from the two renders
    total, noise = rms(loud, far, 10) ** 2, rms(quiet, far, 10) ** 2
    assert 10 * math.log10((total - noise) / noise) == pytest.approx(10.0, abs=0.6)


def test_silence_is_the_noise_floor_and_the_onset_arrives_after_the_flight_time():
    room = room_with(4.43, 1.0, on=False)           # 3.43 m ahead: 10 ms = 160 samples
    r = AudioRenderer(room, snr_db=60, seed=1)
    assert np.abs(r.render((1.0, 1.0, 0.0))).max() < 40
    room.source.on = True
    onset = r.render((1.0, 1.0, 0.0)).astype(float)
    first = int(np.argmax(np.abs(onset[:, 0]) > 300))
    # the mic at +45 deg is 0.085 m nearer: 3.345 m / 343 m/s * 16000 = 156 samples,
    # the renderer's kernel latency (24) after the source's first sample
    assert 150 + 24 <= first <= 160 + 24 + 6


@pytest.mark.parametrize("frame, message", [
    ([], "a frame must be an object, not list"),
    ({"rate": 16000, "channels": 4, "n": 1024, "mics": []}, "frame has no 'pcm'"),
    ({"rate": 16000, "channels": 0, "n": 1024, "mics": [], "pcm": ""},
     "frame's 'channels' must be a positive integer, not 0"),
    ({"rate": 16000, "channels": 4, "n": 2, "mics": [], "pcm": "!!"}, "frame's 'pcm' is not base64"),
    ({"rate": 16000, "channels": 4, "n": 2, "mics": [], "pcm": "AAAA"},
     "frame's 'pcm' holds 3 bytes, not 16 (2 samples x 4 channels x 2)"),
    ({"rate": 16000, "channels": 1, "n": 1, "mics": [[0, 0], [1, 1]], "pcm": "AAA="},
     "frame's 'mics' must hold 1 [x, y] positions"),
])
def test_bad_frames_are_refused_by_name(frame, message):
    with pytest.raises(FrameError) as exc:
        decode_frame(frame)
    assert str(exc.value) == message


# --- GCC-PHAT localization --------------------------------------------------------------

@pytest.mark.parametrize("snr, echo, median_goal, p90_goal",
                         [(20, 0.0, 5, 10), (10, 0.0, 5, 10), (0, 0.0, 10, 20), (10, 0.5, 5, 10)])
def test_localize_finds_the_true_bearing(snr, echo, median_goal, p90_goal):
    src = (5.0, 3.0)
    r = AudioRenderer(room_with(*src), snr_db=snr, seed=snr + 100, reflection_gain=echo)
    loc = Localizer(DEFAULT_MICS, RATE)
    rng = np.random.default_rng(snr)
    errors, confidence = [], []
    for _ in range(24):
        pose = (rng.uniform(0.4, 2.6), rng.uniform(0.4, 3.6), rng.uniform(-math.pi, math.pi))
        r.render(pose)
        bearing, conf = loc.locate(r.render(pose).astype(float) / 32768)
        errors.append(angle_error_deg(bearing, bearing_to(pose, *src)))
        confidence.append(conf)
    assert np.median(errors) <= median_goal and np.percentile(errors, 90) <= p90_goal, errors
    assert min(confidence) > 0.25


def test_wall_echoes_arrive_later_than_the_direct_sound():
    """Source and microphone 1 m from a wall: the echo's lag behind the direct sound is
    the image path's extra length over c."""
    room = room_with(1.0, 1.0)
    r = AudioRenderer(room, mics=[(0.0, 0.0), (0.5, 0.0)], snr_db=60, seed=2, reflection_gain=0.6)
    pose = (2.0, 1.0, 0.0)          # mic 0 at (2, 1), 1 m from the source; the wall
    r.render(pose)                  # y = 0 is 1 m away from both
    pcm = r.render(pose).astype(float)
    direct = r._paths(np.array([2.0, 1.0]), (1.0, 1.0))
    # direct 1 m; images across y=0 (1,-1), x=0 (-1,1), the inner wall x=3 (5,1),
    # y=4 (1,7), x=6 (11,1)
    assert sorted(round(d, 3) for d, _ in direct) == [1.0, 2.236, 3.0, 3.0, 6.083, 9.0]
    ac = np.correlate(pcm[:, 0], pcm[:, 0], "full")[len(pcm) - 1:]
    extra = (math.hypot(1, 2) - 1.0) / SPEED_OF_SOUND * RATE        # 58 samples
    assert abs(int(np.argmax(ac[20:80])) + 20 - extra) <= 1


def test_noise_alone_gives_no_confidence():
    r = AudioRenderer(room_with(5.0, 3.0, on=False), snr_db=10, seed=4)
    loc = Localizer(DEFAULT_MICS, RATE)
    assert max(loc.locate(r.render((1, 1, 0)).astype(float) / 32768)[1] for _ in range(10)) < 0.12


def test_localize_refuses_a_frame_of_the_wrong_shape():
    with pytest.raises(ValueError) as exc:
        Localizer(DEFAULT_MICS, RATE).locate(np.zeros((1024, 3)))
    assert str(exc.value) == "expected samples of shape (n, 4), got (1024, 3)"


# --- camera -----------------------------------------------------------------------------

def test_a_marker_straight_ahead_lands_at_the_image_centre():
    room = room_with(2.0, 3.0)
    pose = (1.0, 1.0, math.atan2(2.0, 1.0))
    png = cam.encode(cam.Camera(room).render(pose))
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    img = cam.decode(png)
    assert img.shape == (240, 320, 3)
    cols = cam.marker_columns(img)
    assert len(cols) > 5 and abs(cols.mean() - 160) <= 3


def test_a_marker_off_axis_lands_where_the_pinhole_puts_it_and_a_wall_hides_it():
    room = room_with(2.0, 3.0)
    camera = cam.Camera(room)
    for off_deg in (-20, 12, 25):
        pose = (1.0, 1.0, math.atan2(2.0, 1.0) - math.radians(off_deg))
        cols = cam.marker_columns(camera.render(pose))
        assert abs(cols.mean() - camera.column_of(math.radians(off_deg))) <= 3
    # behind the inner wall (x = 3, y < 2.5): the source at (4.5, 1) from (1.5, 1)
    hidden = room_with(4.5, 1.0)
    assert len(cam.marker_columns(cam.Camera(hidden).render((1.5, 1.0, 0.0)))) == 0
    # the same source seen from its own side of the wall
    assert len(cam.marker_columns(cam.Camera(hidden).render((3.5, 1.0, 0.0)))) > 5


def test_jpeg_pictures_decode_to_the_same_size():
    img = cam.decode(cam.encode(cam.Camera(room_with(2, 3)).render((1, 1, 1)), "jpeg"))
    assert img.shape == (240, 320, 3)
    with pytest.raises(ValueError) as exc:
        cam.encode(img, "gif")
    assert str(exc.value) == "picture format must be 'png' or 'jpeg', not 'gif'"


# --- the room ---------------------------------------------------------------------------

def test_rays_and_line_of_sight():
    room = example_scene()
    dist, wall = room.cast((1.0, 1.0), np.array([0.0, math.pi / 2, math.pi]))
    assert dist == pytest.approx([2.0, 3.0, 1.0]) and list(wall) == [4, 2, 3]
    assert room.blocked((1.0, 1.0), (4.0, 1.0)) and not room.blocked((1.0, 3.0), (4.0, 3.0))
    assert room.clearance((2.5, 1.0)) == pytest.approx(0.5)


@pytest.mark.parametrize("source, message", [
    ({"x": 1}, "source: missing field 'y'"),
    ({"x": 1, "y": 2, "on": "yes"}, "source.on must be true or false, not 'yes'"),
    ({"x": 1, "y": 2, "level": 2}, "source.level must be in (0, 1], not 2.0"),
    ({"x": 1, "y": 2, "loud": 1}, "source: unknown field 'loud' (known: x, y, on, level)"),
])
def test_bad_sources_are_refused_by_name(source, message):
    with pytest.raises(SceneError) as exc:
        Source.from_dict(source)
    assert str(exc.value) == message
