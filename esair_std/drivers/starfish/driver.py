"""``Starfish``: the STARFISH robot's Linux-side devices as ESAIR STD resources, its
wheels and odometry over its MIN link to the emulated boards (docs/std-starfish.md).

Deployment entry (the entry's name prefixes the resources' names)::

    starfish:
      class: esair_std.drivers.starfish:Starfish
      room_file: room.yaml      # THE world (esair_min.world.load_room, mm): the emulated
                                # robot lives in it (--room), the sensors render from it;
                                # landmark kinds 'sound' and 'access_point' place the
                                # source and the radio
      port: emulate             # the driver runs `esair emulate starfish --pty` (only
                                # the emulated world feeds the simulated sensors)
      emulate: {restart: {max: 3, within: 60}, speed: 1}  # that child's options
      pose: [1.0, 1.0, 0.0]     # where the robot starts (x m, y m, heading rad)
      snr_db: 20                # the microphones' SNR at the array's centre
      echo: 0.5                 # wall echoes' gain (0: the direct sound only)
      seed: 0                   # the audio's random streams
      odometry_hz: 10           # O polls a second (at most half the line: 25.6 at
                                # 38400 baud, the longest O reply)
      timeout: 1.0              # the link's reply timeout (MinLink's)
      deadline: 0.5             # a wheel command not written by then is dropped
      radio: {range_m: 3.0, heal_m: 0.1, pause_audio: true}   # device: only ESAIR's own
                                # simulated link (linkswitch.py), never a real interface
      camera: {format: png, fov_deg: 60}
      allow: {"*": read, patrol: command, turn_and_shoot: command}

Resources:

- ``<entry>.wheels`` actuator: ``{"vx": mm/s, "vy": mm/s, "w": mrad/s}`` (robot frame,
  missing keys 0) -> ``V±vvvv±vvvv±wwww``, or ``"stop"`` -> ``x``, over the MIN link;
  the board file's limits refused by name before sending; the central board's 0.5 s
  watchdog stops the robot when no command comes (``!W watchdog stop``);
- ``<entry>.odometry`` sensor: ``{"x", "y", "th", "moving", "squal", "n", "tn",
  "tn_spread"}`` ``odometry_hz`` times a second (each poll a step further into the
  board's tick), and once more when the wheels are at rest after a stop: the flow
  sensors' sums (``O``) integrated from ``pose``; ``n`` is the reply's count of the
  central board's ticks (16 bits): the robot's own clock; ``tn`` when the board read
  the sums, on this computer's clock (tickclock.py), ``tn_spread`` how far off it may be;
- ``<entry>.notices`` sensor: the robot's ``!`` lines (MinLink's);
- ``<entry>.mics`` sensor: the microphone array's frames (mics.py) rendered from the
  world's TRUE pose 15.625 times a second; ``configure(mics, "source", {...})`` places /
  switches the sound source, ``configure(mics, "snr_db", dB)``;
- ``<entry>.camera`` actuator: ``"shoot"`` or ``{"shoot": true, "format": "jpeg"}`` ->
  ``{"seq", "t", "pose", "format", "w", "h", "image"}`` (the picture from the true pose);
- ``<entry>.radio`` sensor: ``{"up", "distance", "los"}`` 5 times a second (radio.py);
  ``pause_audio`` and ``device`` as before (linkswitch.py);
- ``<entry>.pictures`` sensor: each picture the camera takes (the camera's reply);
- ``<entry>.map`` sensor: ``{"walls": [[x1, y1, x2, y2], ...], "landmarks": [...]}`` (m)
  once a second: the room, for a map (the HMI's).

The MIN link is MinLink's (esair_std/drivers/minlink): this driver is a ``MinLink`` whose
robot is STARFISH's boards; the emulated robot is owned by it (reaped, restarted under
``emulate: {restart: ...}``, its ``id=`` checked at every reconnect, the resources
``lost`` with the reason meanwhile). The true pose comes from the emulator on a side
channel (``--world-out``, worldtap.py): the wheels, odometry and notices are the MIN
link's, the world is the emulator's, and the host renders what its Linux-side devices
sense of that one world.
"""

from __future__ import annotations

import base64
import threading
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from esair_std import Actuator, CommandError, Sensor
from esair_min.errors import EsairError

from ..minlink.driver import MinLink, NoticeSensor, emulate_args, in_folder
from ...errors import DeployError
from ..minlink.emulated import EmulatedRobot
from ..minlink.link_errors import LinkError
from ..minlink.link import Link
from ...restart_window import RestartWindow
from .linkswitch import LinkSwitch
from ...transport.codec import JSON, JSONObject

if TYPE_CHECKING:  # pragma: no cover
    from pydantic import BaseModel

    from .worldtap import WorldTap

# the renderers (numpy) and the camera (Pillow) are imported when the driver opens, not
# when its module is imported: the runtime imports every class of a deployment to check
# it, and would otherwise carry numpy and Pillow for the whole run
RATE, FRAME = 16000, 1024
#: the share of the serial line the odometry polls may take; the rest carries the wheels'
#: commands (20-50 a second from the behaviors)
ODOMETRY_SHARE = 0.5
class StarfishError(ValueError):
    """A bad option of the Starfish entry (the message names it)."""


class _Options:
    """A ``Starfish`` entry's options, checked (options.py's ``StarfishOptions``, dumped
    to plain values): what :meth:`Starfish.open` reads of them."""

    def __init__(self, d: dict[str, Any]):
        self.room_file, self.port = str(d["room_file"]), str(d["port"])
        self.pose = tuple(float(v) for v in d["pose"])
        self.odometry_hz, self.timeout = float(d["odometry_hz"]), float(d["timeout"])
        self.deadline, self.snr_db = float(d["deadline"]), float(d["snr_db"])
        self.seed, self.echo = float(d["seed"]), float(d["echo"])
        radio, camera = dict(d["radio"]), dict(d["camera"])
        self.radio_device: str | None = radio["device"]
        self.range_m, self.heal_m = float(radio["range_m"]), float(radio["heal_m"])
        self.pause_audio = bool(radio["pause_audio"])
        self.picture_format, self.fov_deg = str(camera["format"]), float(camera["fov_deg"])
        emulate = dict(d["emulate"])
        restart = dict(emulate.pop("restart", None) or {})
        self.restart_max = int(restart.get("max", 0))
        self.restart_within = float(restart.get("within", 0.0))
        self.emulate: dict[str, object] = emulate        # the child's options


class Mics(Sensor):
    rate_hz = RATE / FRAME
    settings = ("source", "snr_db")

    def __init__(self, robot: "Starfish"):
        self.robot = robot
        self.frames_paused = 0

    def read(self) -> JSONObject | None:
        r = self.robot
        n0 = r.audio.n0
        assert r.tap is not None            # the driver is open
        pcm = r.audio.render(r.tap.pose())
        if r.pause_audio and not r.radio_state()["up"]:
            self.frames_paused += 1
            return None
        return r.encode_frame(pcm, r.audio.seq, n0, r.audio.mics.tolist(), time.time())

    def configure(self, key: str, value: JSON) -> JSON:
        r = self.robot
        if key == "source":
            from .scene import SceneError, Source
            try:
                src = Source.from_dict(value)
            except SceneError as exc:
                raise CommandError(self.name, str(exc)) from None
            r.room.source = src
            return src.to_dict()
        if key == "snr_db":
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not -20 <= value <= 80:
                raise CommandError(self.name, f"snr_db must be a number in -20..80, not {value!r}")
            r.audio.snr_db = float(value)
            return float(value)
        raise self.no_setting(key)


class CameraShoot(Actuator):
    def __init__(self, robot: "Starfish"):
        self.robot = robot
        self.seq = 0

    def write(self, command: JSON) -> JSONObject:
        fmt: JSON = self.robot.picture_format
        if isinstance(command, dict) and command.get("shoot") is True and set(command) <= {"shoot", "format"}:
            fmt = command.get("format", fmt)
        elif command != "shoot":
            raise CommandError(self.name, f"expected 'shoot' or {{'shoot': true, 'format': "
                                          f"'png'|'jpeg'}}, got {command!r}")
        if not isinstance(fmt, str) or fmt not in ("png", "jpeg"):
            raise CommandError(self.name, f"picture format must be 'png' or 'jpeg', not {fmt!r}")
        assert self.robot.tap is not None   # the driver is open
        pose = self.robot.tap.pose()
        data = self.robot.encode_picture(self.robot.camera.render(pose), fmt)
        self.seq += 1
        pic: JSONObject = {"seq": self.seq, "t": time.time(), "pose": [round(v, 4) for v in pose],
               "format": fmt, "w": self.robot.camera.width, "h": self.robot.camera.height,
               "image": base64.b64encode(data).decode("ascii")}
        self.robot.pictures.report(pic)        # for watchers (the HMI): the last picture
        return pic


class Pictures(Sensor):
    """Each picture the camera takes, as it was returned to the one who asked for it
    (an image sensor: the HMI shows the last one)."""


class RoomMap(Sensor):
    """The room the robot lives in, once a second: walls, landmarks, the sound source
    and the access point (m; the odometry's frame). A page opened late gets it within a
    second; the source moves when it is configured."""

    rate_hz = 1.0

    def __init__(self, robot: "Starfish"):
        self.robot = robot

    def read(self) -> JSONObject:
        room, radio = self.robot.room, self.robot.radio
        marks: list[JSON] = [
            {"kind": "pole", "x": lm["x"], "y": lm["y"], "r": lm["r"], "color": list(lm["color"])}
            for lm in room.landmarks]
        src = room.source
        marks.append({"kind": "sound", "x": src.x, "y": src.y, "on": src.on})
        ap = room.access_point
        marks.append({"kind": "access_point", "x": ap[0], "y": ap[1], "range_m": radio.range_m})
        return {"walls": [[round(float(v), 4) for v in w] for w in room.walls], "landmarks": marks}


class Radio(Sensor):
    rate_hz = 5.0

    def __init__(self, robot: "Starfish"):
        self.robot = robot

    def read(self) -> JSONObject:
        return self.robot.radio_state()


class Starfish(MinLink):
    """STARFISH's wheels, odometry and notices over its MIN link; its microphones, camera
    and radio rendered from the emulated world (see the module docstring)."""

    #: the entry's options (checked with the deployment, each error at its line): named,
    #: not imported, so that a robot side handed them checked never loads pydantic
    Options: type[BaseModel] | str = "esair_std.drivers.starfish.options:StarfishOptions"

    @classmethod
    def prepare_entry(cls, options: dict[str, object], base_dir: str | Path | None,
                      name: str) -> JSONObject | None:
        """What :meth:`open` needs, as plain JSON: the options checked, the board files'
        path and what the driver uses of their model (omniboard.py), and the files read
        (``inputs``). ``esair std run`` calls it where the deployment is checked (the
        robot side then imports neither pydantic nor the model); ``open`` calls it when
        it was not. What needs the room or the line ``open`` checks."""
        from ...deploy.class_options import check_options
        from .options import StarfishOptions
        from .omniboard import prepare_omni
        try:
            o = check_options(StarfishOptions, dict(options))
        except DeployError as exc:      # an entry added at run time: its options' paths
            raise StarfishError(str(exc)) from None
        assert isinstance(o, StarfishOptions)
        base = Path(base_dir or ".")                      # the deployment file's folder
        try:
            omni, path, inputs = prepare_omni(str(o.robot), base)
        except ValueError as exc:
            raise StarfishError(str(exc)) from None
        return {"options": o.model_dump(mode="json"), "path": str(path),
                "omni": omni.to_json(), "inputs": inputs}

    def open(self) -> None:
        self.tap: WorldTap | None = None
        self.link_switch: LinkSwitch | None = None
        try:
            self._open(dict(self.options))
        except (ValueError, LinkError) as exc:    # StarfishError, SceneError included
            self.close()
            raise StarfishError(f"{self.name}: {exc}") from None
        except BaseException:
            self.close()
            raise

    def _open(self, opts: dict[str, object]) -> None:
        from .camera import Camera, encode
        from .mics import AudioRenderer, encode_frame
        from .omniboard import OmniBoard
        from .omnilink import Odometry, OmniCommands, Wheels, omni_budget
        from .radio import RadioModel
        from .scene import load_scene
        from .worldtap import WorldTap
        self.encode_frame, self.encode_picture = encode_frame, encode
        spec = self._esair.spec
        base = Path(getattr(spec, "base_dir", None) or ".")   # the deployment file's folder
        prepared: Any = getattr(spec, "prepared", None)
        if not prepared or "omni" not in prepared:       # not prepared beforehand
            prepared = self.prepare_entry(opts, base, self.name)
            assert prepared is not None
        o = _Options(prepared["options"])
        path = Path(str(prepared["path"]))
        robot = OmniBoard.from_json(prepared["omni"])
        if o.port != "emulate":
            raise StarfishError(f"port {o.port!r}: the simulated microphones, camera and "
                                "radio need the emulated world (port: emulate)")
        room_file = in_folder(base, o.room_file)
        try:
            self.room = load_scene(room_file)
        except EsairError as exc:
            raise StarfishError(f"room_file: {exc}") from None
        start = (o.pose[0], o.pose[1], o.pose[2])
        if self.room.clearance(start[:2]) < 0.15:
            raise StarfishError(f"start pose ({start[0]}, {start[1]}) is closer than 0.15 m "
                                f"to a wall")
        hz, timeout, deadline = o.odometry_hz, o.timeout, o.deadline
        budget = omni_budget(robot)         # the line's, known before the robot starts
        if hz > budget.max_feet_hz(ODOMETRY_SHARE):
            raise StarfishError(f"odometry_hz {hz:g} exceeds the line: at {budget.baud} baud one "
                                f"'O' exchange takes up to {budget.feet_exchange_s * 1e3:.1f} ms, "
                                f"and the polls may take half the line (the wheels' commands the "
                                f"other half): at most {budget.max_feet_hz(ODOMETRY_SHARE):.1f} a "
                                f"second")
        self.audio = AudioRenderer(self.room, snr_db=o.snr_db, seed=int(o.seed),
                                   reflection_gain=o.echo)
        emulate = o.emulate
        bad = sorted(set(emulate) & {"room", "pose", "world_out", "instance"})
        if bad:
            raise StarfishError(f"option 'emulate.{bad[0]}' is the driver's own (give "
                                f"room_file and pose)")
        self.radio = RadioModel(self.room, o.range_m, o.heal_m)
        self.pause_audio = o.pause_audio
        self.picture_format = o.picture_format
        self.camera = Camera(self.room, fov_deg=o.fov_deg)
        self._radio_lock = threading.Lock()
        # before anything starts: a device ESAIR did not make is refused, nothing changed
        self.link_switch = LinkSwitch(o.radio_device) if o.radio_device else None
        # the world first (its socket bound before the emulator sends), then the robot
        self.tap = WorldTap(start)
        self.children: dict[str, Sensor | Actuator] = {}
        self._closing = threading.Event()
        self._lost: str | None = None
        self._supervisor: threading.Thread | None = None
        self._restarts = RestartWindow(o.restart_max, o.restart_within)
        args = emulate_args(emulate, base) + [
            "--room", room_file, "--world-out", self.tap.path,
            "--pose", f"{start[0] * 1000:.1f},{start[1] * 1000:.1f},{start[2]:.6f}"]
        self.emulated = EmulatedRobot(path, args)
        self._starts = 0
        port = self.emulated.start()
        self._starts = self.emulated.starts
        self.notices = NoticeSensor()
        self.link = Link(robot.board, str(port), timeout=timeout, on_state=self._link_state,
                         on_notice=self.notices.notice, expect_id=self.emulated.instance,
                         may_open=self.emulated.held, commands=OmniCommands(robot),
                         budget=budget)
        self.link.open()
        self.odometry = Odometry(self.link, robot, hz, start)
        self.wheels = Wheels(self.link, robot.max_speed_mm_s, robot.max_omega_mrad_s,
                             robot, self.odometry.poll_at)
        kids: dict[str, Sensor | Actuator] = {"wheels": self.wheels, "odometry": self.odometry,
                                "notices": self.notices}
        self.wheels.deadline_s = deadline
        self.children = kids
        self.pictures = Pictures()
        self.simulated: dict[str, Sensor | Actuator] = {
            "mics": Mics(self), "camera": CameraShoot(self), "radio": Radio(self),
            "pictures": self.pictures, "map": RoomMap(self)}
        self._supervisor = threading.Thread(target=self._supervise, daemon=True,
                                            name=f"minlink-emulator:{self.name}")
        self._supervisor.start()

    def _link_state(self, up: bool, reason: str) -> None:
        emulated = getattr(self, "emulated", None)
        if up and emulated is not None and emulated.starts != self._starts:
            # a restarted robot: its world and its flow sums start again at the start pose
            self._starts = emulated.starts
            assert self.tap is not None
            self.tap.restart()
            self.odometry.reset()
        super()._link_state(up, reason)

    def radio_state(self) -> JSONObject:
        assert self.tap is not None         # the driver is open
        x, y, _ = self.tap.pose()
        with self._radio_lock:
            state = self.radio.update(x, y)
        if self.link_switch is not None:
            self.link_switch.set(state["up"] is True)     # a bool (RadioModel.update)
        return state

    def resources(self) -> dict[str, Sensor | Actuator]:
        return {**self.children, **getattr(self, "simulated", {})}

    def close(self) -> None:
        super().close()             # the link, then the emulated robot
        switch, tap = getattr(self, "link_switch", None), getattr(self, "tap", None)
        self.link_switch = self.tap = None
        if switch is not None:
            switch.close()
        if tap is not None:
            tap.close()
