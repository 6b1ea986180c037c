"""``Starfish``: the STARFISH robot's Linux-side devices as ESAIR STD resources, in
simulation (docs/std-starfish.md).

Deployment entry (the entry's name prefixes the resources' names)::

    starfish:
      class: esair_std.drivers.starfish:Starfish
      world: standin            # the only world today: standin.py (see below)
      room: {...}               # room.py's format; missing keys from its DEFAULT_ROOM
      pose: [1.0, 1.0, 0.0]     # where the robot starts (x m, y m, heading rad)
      snr_db: 20                # the microphones' SNR at the array's centre
      echo: 0.5                 # wall echoes' gain (0: the direct sound only)
      seed: 0                   # the audio's random streams
      odometry_hz: 20
      radio: {range_m: 3.0, heal_m: 0.1, pause_audio: true, device: eth1}
      camera: {format: png, fov_deg: 60}
      allow: {"*": read, patrol: command, turn_and_shoot: command}

Resources:

- ``<entry>.wheels`` actuator: ``{"vx": mm/s, "vy": mm/s, "w": mrad/s}`` (robot frame,
  missing keys 0) or ``"stop"``; limits refused by name; a 0.5 s command watchdog stops
  the robot. ``configure(wheels, "pose", [x, y, th])`` puts the robot somewhere (the
  operator's hand: simulation only);
- ``<entry>.odometry`` sensor: ``{"x", "y", "th", "moving"}`` ``odometry_hz`` times a
  second;
- ``<entry>.mics`` sensor: the microphone array's frames (mics.py: 4 x 1024 int16 at
  16 kHz, base64, ``seq`` and ``n0`` numbering the stream) 15.625 times a second;
  ``configure(mics, "source", {"x", "y", "on", "level"})`` places / switches the room's
  sound source, ``configure(mics, "snr_db", dB)``;
- ``<entry>.camera`` actuator: ``"shoot"`` or ``{"shoot": true, "format": "jpeg"}`` ->
  ``{"seq", "t", "pose", "format", "w", "h", "image"}`` (``image``: base64 of the PNG or
  JPEG of the room seen from the robot's pose, camera.py);
- ``<entry>.radio`` sensor: ``{"up", "distance", "los"}`` 5 times a second (radio.py).
  With ``radio.pause_audio`` (the default), while the link is cut the microphone frames
  are not reported (``frames_paused`` counts them): on one computer, where the remote
  control center's behaviors run beside the robot's, that is the cut radio's effect on
  what they hear. With ``radio.device`` the driver also sets that network interface
  down while the link is cut and up when it heals (``ip link set DEV down|up``,
  linkswitch.py): the namespace tests and the two-computer demo cut the real link to
  the remote control center this way (then set ``pause_audio: false``).

``world: standin`` is ``standin.py``, a stand-in for issue 22's emulated STARFISH (its
boards and their world): the pose integrated from the commanded velocity. When that
emulator lands, the wheels and odometry go through its MIN link (the MinLink design)
and the pose the microphones, camera and radio are rendered from is its world's.
"""

from __future__ import annotations

import base64
import math
import time
from typing import Any

from esair_std import Actuator, CommandError, Driver, Sensor

from .linkswitch import LinkSwitch

# the world (numpy) and the camera (Pillow) are imported when the driver opens, not when
# its module is imported: the runtime imports every class of a deployment to check it,
# and would otherwise carry numpy and Pillow for the whole run
RATE, FRAME = 16000, 1024


class StarfishError(ValueError):
    """A bad option of the Starfish entry (the message names it)."""


def _num(opts: dict, key: str, default: float, what: str = "") -> float:
    value = opts.get(key, default)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise StarfishError(f"option '{what}{key}' must be a number, not {value!r}")
    return float(value)


class Wheels(Actuator):
    def __init__(self, robot: "Starfish"):
        self.robot = robot

    def write(self, command: Any) -> Any:
        if command == "stop":
            command = {}
        if not isinstance(command, dict) or set(command) - {"vx", "vy", "w"}:
            raise CommandError(self.name, f"expected {{'vx': mm/s, 'vy': mm/s, 'w': mrad/s}} or "
                                          f"'stop', got {command!r}")
        vx, vy, w = (command.get(k, 0) for k in ("vx", "vy", "w"))
        try:
            self.robot.world.command(vx, vy, w)
        except ValueError as exc:                  # standin.CommandRefused
            raise CommandError(self.name, str(exc)) from None
        return {"vx": vx, "vy": vy, "w": w}

    def configure(self, key: str, value: Any) -> Any:
        if key == "pose":
            if (not isinstance(value, list) or len(value) != 3 or not all(
                    isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)):
                raise CommandError(self.name, f"pose must be [x, y, heading], not {value!r}")
            try:
                self.robot.world.place(*value)
            except ValueError as exc:
                raise CommandError(self.name, str(exc)) from None
            return value
        raise CommandError(self.name, f"no setting {key!r} (settings: pose)")


class Odometry(Sensor):
    def __init__(self, robot: "Starfish", hz: float):
        self.robot, self.rate_hz = robot, hz

    def read(self) -> Any:
        x, y, th = self.robot.world.pose()
        return {"x": round(x, 4), "y": round(y, 4), "th": round(th, 5),
                "moving": self.robot.world.moving()}


class Mics(Sensor):
    rate_hz = RATE / FRAME

    def __init__(self, robot: "Starfish"):
        self.robot = robot
        self.frames_paused = 0

    def read(self) -> Any:
        r = self.robot
        n0 = r.audio.n0
        pcm = r.audio.render(r.world.pose())
        if r.pause_audio and not r.radio_state()["up"]:
            self.frames_paused += 1
            return None
        return r.encode_frame(pcm, r.audio.seq, n0, r.audio.mics.tolist(), time.time())

    def configure(self, key: str, value: Any) -> Any:
        r = self.robot
        if key == "source":
            from .room import RoomError, Source
            try:
                src = Source.from_dict(value)
            except RoomError as exc:
                raise CommandError(self.name, str(exc)) from None
            r.room.source = src
            return src.to_dict()
        if key == "snr_db":
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not -20 <= value <= 80:
                raise CommandError(self.name, f"snr_db must be a number in -20..80, not {value!r}")
            r.audio.snr_db = float(value)
            return float(value)
        raise CommandError(self.name, f"no setting {key!r} (settings: source, snr_db)")


class CameraShoot(Actuator):
    def __init__(self, robot: "Starfish"):
        self.robot = robot
        self.seq = 0

    def write(self, command: Any) -> Any:
        fmt = self.robot.picture_format
        if isinstance(command, dict) and command.get("shoot") is True and set(command) <= {"shoot", "format"}:
            fmt = command.get("format", fmt)
        elif command != "shoot":
            raise CommandError(self.name, f"expected 'shoot' or {{'shoot': true, 'format': "
                                          f"'png'|'jpeg'}}, got {command!r}")
        if fmt not in ("png", "jpeg"):
            raise CommandError(self.name, f"picture format must be 'png' or 'jpeg', not {fmt!r}")
        pose = self.robot.world.pose()
        data = self.robot.encode_picture(self.robot.camera.render(pose), fmt)
        self.seq += 1
        return {"seq": self.seq, "t": time.time(), "pose": [round(v, 4) for v in pose],
                "format": fmt, "w": self.robot.camera.width, "h": self.robot.camera.height,
                "image": base64.b64encode(data).decode("ascii")}


class Radio(Sensor):
    rate_hz = 5.0

    def __init__(self, robot: "Starfish"):
        self.robot = robot

    def read(self) -> Any:
        return self.robot.radio_state()


class Starfish(Driver):
    """STARFISH's wheels, odometry, microphones, camera and radio (module docstring)."""

    def open(self) -> None:
        try:
            self._open(dict(self.options))
        except ValueError as exc:          # StarfishError, RoomError included
            raise StarfishError(f"{self.name}: {exc}") from None

    def _open(self, opts: dict) -> None:
        from .camera import Camera, encode
        from .mics import AudioRenderer, encode_frame
        from .radio import RadioModel
        from .room import Room
        from .standin import StandInWorld
        self.encode_frame, self.encode_picture = encode_frame, encode
        known = {"world", "room", "pose", "snr_db", "echo", "seed", "odometry_hz", "radio", "camera"}
        unknown = sorted(set(opts) - known)
        if unknown:
            raise StarfishError(f"unknown option {unknown[0]!r} "
                                f"(options: {', '.join(sorted(known))})")
        if opts.get("world", "standin") != "standin":
            raise StarfishError(f"world {opts['world']!r} is not available "
                                "(only 'standin' until STARFISH's emulator lands)")
        self.room = Room.from_dict(opts.get("room"))
        pose = opts.get("pose", [1.0, 1.0, 0.0])
        if not isinstance(pose, list) or len(pose) != 3 or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in pose):
            raise StarfishError(f"option 'pose' must be [x, y, heading], not {pose!r}")
        self.world = StandInWorld(self.room, pose)
        self.audio = AudioRenderer(self.room, snr_db=_num(opts, "snr_db", 20.0),
                                   seed=int(_num(opts, "seed", 0)),
                                   reflection_gain=_num(opts, "echo", 0.5))
        radio = opts.get("radio") or {}
        cam = opts.get("camera") or {}
        if not isinstance(radio, dict) or not isinstance(cam, dict):
            raise StarfishError("options 'radio' and 'camera' must be mappings")
        self.radio = RadioModel(self.room, _num(radio, "range_m", 3.0, "radio."),
                                _num(radio, "heal_m", 0.1, "radio."))
        self.pause_audio = bool(radio.get("pause_audio", True))
        unknown = sorted(set(radio) - {"range_m", "heal_m", "pause_audio", "device"})
        if unknown:
            raise StarfishError(f"unknown option 'radio.{unknown[0]}' (radio options: device, "
                                "heal_m, pause_audio, range_m)")
        self.link = LinkSwitch(str(radio["device"])) if radio.get("device") else None
        self.picture_format = cam.get("format", "png")
        if self.picture_format not in ("png", "jpeg"):
            raise StarfishError(f"camera.format must be 'png' or 'jpeg', "
                                f"not {self.picture_format!r}")
        self.camera = Camera(self.room, fov_deg=_num(cam, "fov_deg", 60.0, "camera."))
        hz = _num(opts, "odometry_hz", 20.0)
        if not 0 < hz <= 200:
            raise StarfishError(f"odometry_hz must be in (0, 200], not {hz:g}")
        self.children = {"wheels": Wheels(self), "odometry": Odometry(self, hz), "mics": Mics(self),
                         "camera": CameraShoot(self), "radio": Radio(self)}

    def radio_state(self) -> dict:
        x, y, _ = self.world.pose()
        state = self.radio.update(x, y)
        if self.link is not None:
            self.link.set(state["up"])
        return state

    def resources(self) -> dict[str, Any]:
        return self.children

    def close(self) -> None:
        link = getattr(self, "link", None)
        if link is not None:
            link.close()
        world = getattr(self, "world", None)
        if world is not None:
            world.vx = world.vy = world.w = 0.0      # nothing moves once the driver is gone
