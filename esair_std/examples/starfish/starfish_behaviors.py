"""STARFISH's three behaviors and its reaction (thesis 5.1; starfish.yaml,
docs/std-starfish.md).

- ``Patrol`` (on the robot): follows the waypoints, forever; yields the wheels when
  ``turn_and_shoot`` asks (a put ``{"yield": seconds}``, back on ``{"resume": true}`` or
  when those seconds are over) and while the radio is down (``reconnect`` drives then).
- ``Localize`` (remote control center): the bearing of the sound from each microphone
  frame (GCC-PHAT over the 6 pairs), put to ``turn_and_shoot`` when confident.
- ``TurnAndShoot`` (remote): on a confident bearing takes the wheels from ``patrol``,
  turns the robot to face the source, takes a picture, stores it with its pose and time,
  gives the wheels back.
- ``Reconnect`` (reaction, on the robot): when the radio link drops, drives back to the
  last pose where it was up, on a path around the walls; stops when the link is back.
"""

from __future__ import annotations

import base64
import collections
import json
import math
import time
from pathlib import Path
from typing import TYPE_CHECKING

from esair_std import Behavior, CommandError, Reaction, Refused, ResourceLost

if TYPE_CHECKING:  # pragma: no cover
    from esair_std.drivers.starfish.gccphat import Localizer

# numpy and scipy (the room, the planner, GCC-PHAT) are imported in start() by the
# components that need them, so patrol's process and the runtime do not carry them


def wrap(angle: float) -> float:
    """An angle in (-pi, pi]."""
    a = math.fmod(angle + math.pi, 2 * math.pi)
    if a <= 0:
        a += 2 * math.pi
    return a - math.pi


def _clamp(v: float, lim: float) -> float:
    return max(-lim, min(lim, v))


def drive_towards(pose: dict, target: tuple[float, float], speed: float) -> dict:
    """The body velocity (mm/s, robot frame) that heads for ``target`` at ``speed``,
    slowing down in the last 0.3 m; the heading is kept."""
    dx, dy = target[0] - pose["x"], target[1] - pose["y"]
    dist = math.hypot(dx, dy)
    v = speed * min(1.0, dist / 0.3) if dist > 1e-6 else 0.0
    c, s = math.cos(pose["th"]), math.sin(pose["th"])
    ux, uy = (dx / dist, dy / dist) if dist > 1e-6 else (0.0, 0.0)
    return {"vx": round(v * (c * ux + s * uy)), "vy": round(v * (-s * ux + c * uy)), "w": 0}


# deadline: a step that waits for the wheels (0.3 s at most) on a loaded computer must
# not fail the component: 3 s, the same for every STARFISH component


class Patrol(Behavior):
    period = 0.05
    deadline = 3.0

    def start(self):
        pts = self.options.get("waypoints") or [[1.0, 1.0], [2.5, 1.0], [2.5, 3.2], [1.0, 3.2]]
        self.waypoints = [(float(x), float(y)) for x, y in pts]
        self.speed = float(self.options.get("speed", 200))          # mm/s
        self.tolerance = float(self.options.get("tolerance", 0.08))  # m
        self.odometry = self.attach_sensor("starfish.odometry", keep=4)
        self.radio = self.attach_sensor("starfish.radio", keep=4)
        self.wheels = self.attach_actuator("starfish.wheels")
        self.index = 0
        self.yielded_until = 0.0
        self.yielded_to = None
        self.was_driving = False
        self.laps = 0
        self.reached = 0
        self.link_losses = 0
        self.radio_up = True

    def receive(self, sender, data):
        if isinstance(data, dict) and "yield" in data:
            self.yielded_until = time.monotonic() + float(data["yield"])
            self.yielded_to = sender
        elif isinstance(data, dict) and data.get("resume"):
            self.yielded_until = 0.0
            self.yielded_to = None

    def step(self):
        r = self.radio.latest()
        up = r is None or r.value["up"]
        if self.radio_up and not up:
            self.link_losses += 1
            self.index = (self.index + 1) % len(self.waypoints)   # skip the one out of range
        self.radio_up = up
        pose = self.odometry.latest()
        if not up or time.monotonic() < self.yielded_until or pose is None:
            if self.was_driving and up:
                self._send("stop")          # handing over to turn_and_shoot: stand still
            self.was_driving = False
            return                          # reconnect drives while the link is down
        target = self.waypoints[self.index]
        if math.hypot(target[0] - pose.value["x"], target[1] - pose.value["y"]) < self.tolerance:
            self.reached += 1
            self.index = (self.index + 1) % len(self.waypoints)
            self.laps += self.index == 0
            target = self.waypoints[self.index]
        self.was_driving = self._send(drive_towards(pose.value, target, self.speed))

    def _send(self, command) -> bool:
        try:
            self.wheels.send(command, timeout=0.3)
            return True
        except (CommandError, ResourceLost, Refused) as exc:
            self.log.warning("wheels: %s", exc)
            return False

    def provide(self, requester):
        return {"waypoint": self.index, "reached": self.reached, "laps": self.laps,
                "link_losses": self.link_losses, "yielded_to": self.yielded_to
                if time.monotonic() < self.yielded_until else None}


class Localize(Behavior):
    period = 0.05
    deadline = 3.0

    def start(self):
        from esair_std.drivers.starfish.gccphat import Localizer   # numpy/scipy: remote side
        from esair_std.drivers.starfish.mics import FrameError, decode_frame
        self._Localizer: type[Localizer] = Localizer
        self._decode, self._FrameError = decode_frame, FrameError
        self.target = self.options.get("target", "turn_and_shoot")
        self.min_confidence = float(self.options.get("min_confidence", 0.3))
        # frames localized per step at most: a backlog (a slow or loaded computer) is
        # skipped, newest kept, and counted, rather than the step overrunning its deadline
        self.max_per_step = int(self.options.get("max_per_step", 3))
        self.skipped = 0
        self.mics = self.attach_sensor("starfish.mics", keep=16)
        self.localizer: Localizer | None = None
        self.geometry = None
        self.frames = self.bad_frames = self.confident = self.published = 0
        self.lost_frames = 0                 # holes in the frames' own sequence numbers
        self.last_seq = None
        self.last = None

    def step(self):
        frames = self.mics.samples()
        if len(frames) > self.max_per_step:
            self.skipped += len(frames) - self.max_per_step
            seq = frames[-self.max_per_step - 1].value.get("seq") if isinstance(
                frames[-self.max_per_step - 1].value, dict) else None
            self.last_seq = seq if isinstance(seq, int) else self.last_seq   # not lost: skipped
            frames = frames[-self.max_per_step:]
        for s in frames:
            try:
                pcm, mics, rate = self._decode(s.value)
            except self._FrameError as exc:
                self.bad_frames += 1
                self.log.warning("frame %s: %s", s.seq, exc)
                continue
            self.frames += 1
            seq = s.value.get("seq")
            if isinstance(seq, int) and self.last_seq is not None and seq > self.last_seq + 1:
                self.lost_frames += seq - self.last_seq - 1
            self.last_seq = seq if isinstance(seq, int) else self.last_seq
            key = (rate, mics.tobytes())
            if key != self.geometry:
                self.localizer, self.geometry = self._Localizer(mics, rate), key
            assert self.localizer is not None           # made with the geometry
            bearing, conf = self.localizer.locate(pcm)
            self.last = {"bearing": round(bearing, 5), "confidence": round(conf, 3),
                         "frame": s.value.get("seq"), "t": s.value.get("t")}
            if conf >= self.min_confidence:
                self.confident += 1
                if self.put(self.target, self.last, timeout=0.2):
                    self.published += 1

    def provide(self, requester):
        return {"last": self.last, "frames": self.frames, "lost_frames": self.lost_frames,
                "skipped": self.skipped,
                "bad_frames": self.bad_frames,
                "confident": self.confident, "published": self.published,
                "overwritten": self.mics.overwritten}


class TurnAndShoot(Behavior):
    period = 0.02
    deadline = 3.0

    def start(self):
        self.patrol = self.options.get("patrol", "patrol")
        self.tolerance = math.radians(float(self.options.get("tolerance_deg", 1.5)))
        self.max_turn = float(self.options.get("max_turn", 2500))        # mrad/s
        self.cooldown = float(self.options.get("cooldown", 5.0))          # s between shots
        self.turn_timeout = float(self.options.get("turn_timeout", 6.0))
        # a wheel command refused, failed or unanswered is logged and the next step sends
        # again; the shot is given up only when no wheel command went through for this long
        self.wheels_silent = float(self.options.get("wheels_silent_s", 2.0))
        self.gain = float(self.options.get("gain", 5000.0))               # mrad/s per rad
        self.store = Path(self.options.get("store", "starfish-pictures"))
        self.keep = int(self.options.get("keep", 20))
        self.odometry = self.attach_sensor("starfish.odometry", keep=64)
        self.wheels = self.attach_actuator("starfish.wheels")
        self.camera = self.attach_actuator("starfish.camera")
        # (t, th) from the odometry
        self.headings: collections.deque[tuple[float, float]] = collections.deque(maxlen=200)
        self.pending = None
        self.phase = "idle"
        self.target = 0.0
        self.since = 0.0
        self.quiet_until = 0.0
        self.pictures = []
        self.shots = self.aborted = self.ignored = self.missed = 0
        self.wheels_ok_at = 0.0             # when a wheel command last went through
        self.still = self.rounds = 0
        self.stood_at = 0.0

    def receive(self, sender, data):
        if self.phase == "checking":
            self.pending = data             # a bearing heard since the robot stopped?
            return
        if self.phase != "idle" or time.monotonic() < self.quiet_until:
            self.ignored += 1
            return
        self.pending = data

    def _heading_at(self, t: float | None) -> float | None:
        if not self.headings:
            return None
        if t is None:
            return self.headings[-1][1]
        return min(self.headings, key=lambda h: abs(h[0] - t))[1]

    def step(self):
        for s in self.odometry.samples():
            self.headings.append((s.t, s.value["th"]))
            # odometry samples in a row that saw the robot standing
            self.still = 0 if s.value.get("moving", True) else self.still + 1
        if self.phase == "idle" and self.pending is not None:
            data, self.pending = self.pending, None
            th = self._heading_at(data.get("t"))
            if th is None:
                return
            self.target = wrap(th + float(data["bearing"]))
            self.bearing = data
            self.put(self.patrol, {"yield": self.turn_timeout + 2.0}, timeout=0.3)
            self.phase, self.since, self.rounds = "turning", time.monotonic(), 0
            self.wheels_ok_at = self.since
        if self.phase == "checking":
            # the source heard again from where the robot stands now: it moved on while the
            # bearing travelled (patrol, the drive board's ramp), so aim again if need be
            data, self.pending = self.pending, None
            if data is None or float(data.get("t", 0)) < self.stood_at:
                if time.monotonic() - self.since > self.turn_timeout:
                    self._shoot()           # no newer bearing: the last aim stands
                    self._done()
                return
            if abs(float(data["bearing"])) <= 2 * self.tolerance or self.rounds >= 3:
                self._shoot()
                self._done()
                return
            th = self._heading_at(data.get("t"))
            if th is None:
                return
            self.target = wrap(th + float(data["bearing"]))
            self.phase = "turning"
            self.rounds += 1
        if self.phase != "turning":
            return
        if not self.headings:
            return
        err = wrap(self.target - self.headings[-1][1])
        try:
            if abs(err) <= self.tolerance:
                # the wheels ramp down after the stop (the drive board's ramp): shoot only
                # once the odometry says the robot stands, and turn again if it drifted
                self._wheels("stop")
                if self.still < 2:
                    return
                self.phase, self.stood_at = "checking", time.time()
            elif time.monotonic() - self.since > self.turn_timeout:
                self._wheels("stop")
                self.aborted += 1
                self._done()
            else:
                w = _clamp(err * self.gain, self.max_turn)
                w = math.copysign(max(abs(w), 150.0), w)
                self._wheels({"w": round(w)})
        except (CommandError, ResourceLost, Refused) as exc:
            # a slow, failed or refused reply: the next step sends again (the drive
            # board's watchdog stops the wheels meanwhile if nothing comes)
            self.missed += 1
            silent = time.monotonic() - self.wheels_ok_at
            if silent <= self.wheels_silent:
                self.log.warning("turn: %s; sending again", exc)
                return
            self.log.warning("turn: %s; the wheels silent for %.1f s: shot given up", exc, silent)
            self.aborted += 1
            self._done()

    def _wheels(self, command):
        self.wheels.send(command, timeout=0.5)
        self.wheels_ok_at = time.monotonic()

    def _shoot(self):
        pic = self.camera.send("shoot", timeout=2.0)
        self.shots += 1
        self.store.mkdir(parents=True, exist_ok=True)
        stem = f"starfish-{self.shots:05d}"
        image = base64.b64decode(pic["image"])
        (self.store / f"{stem}.{'png' if pic['format'] == 'png' else 'jpg'}").write_bytes(image)
        meta = {"file": f"{stem}.{'png' if pic['format'] == 'png' else 'jpg'}", "pose": pic["pose"],
                "t": pic["t"], "bearing": self.bearing, "bytes": len(image)}
        (self.store / f"{stem}.json").write_text(json.dumps(meta))
        self.pictures = (self.pictures + [meta])[-self.keep:]

    def _done(self):
        self.put(self.patrol, {"resume": True}, timeout=0.3)
        self.phase = "idle"
        self.quiet_until = time.monotonic() + self.cooldown
        self.pending = None

    def provide(self, requester):
        return {"state": self.phase, "shots": self.shots, "aborted": self.aborted,
                "ignored": self.ignored, "missed": self.missed,
                "last": self.pictures[-1] if self.pictures else None,
                "store": str(self.store.resolve())}


class Reconnect(Reaction):
    period = 0.05
    deadline = 3.0

    def start(self):
        from esair_std.drivers.starfish.planner import NoPath, plan
        from esair_std.drivers.starfish.scene import load_scene
        self._plan, self._NoPath = plan, NoPath
        # the world's room file, as the driver's (relative: to the deployment file's folder)
        room_file = self.options.get("room_file")
        if not room_file:
            raise ValueError("reconnect: option 'room_file' is missing (the robot's room)")
        path = Path(str(room_file))
        if not path.is_absolute():
            path = Path(getattr(self._esair.spec, "base_dir", None) or ".") / path
        self.room = load_scene(path)
        self.speed = float(self.options.get("speed", 250))
        self.margin = float(self.options.get("margin", 0.25))
        self.radio = self.resource("starfish.radio")
        self.odometry = self.resource("starfish.odometry")
        self.wheels = self.resource("starfish.wheels")
        self.back_s = float(self.options.get("back_s", 1.0))
        # (t, x, y) while the link is up
        self.up_poses: collections.deque[tuple[float, float, float]] = collections.deque(maxlen=400)
        self.last_good = None
        self.path = None
        self.down = False
        self.to_ap = False
        self.trips = self.arrived = self.no_path = 0

    def step(self):
        r, od = self.radio.latest(), self.odometry.latest()
        if r is None or od is None:
            return
        pose = od.value
        if r.value["up"]:
            self.up_poses.append((od.t, pose["x"], pose["y"]))
            if self.down:
                self.down, self.path = False, None
                self._send("stop")              # patrol takes over
            return
        if not self.down:
            self.down = True
            self.to_ap = False
            self.trips += 1
            # where the link was up, back_s before it dropped: the model's hysteresis
            # heals the link a little inside the edge where it was cut
            t_cut = self.up_poses[-1][0] - self.back_s if self.up_poses else 0.0
            before = [p for p in self.up_poses if p[0] <= t_cut] or list(self.up_poses)[:1]
            self.last_good = (before[-1][1], before[-1][2]) if before else None
            try:
                self.path = self._plan(self.room, (pose["x"], pose["y"]), self.last_good or
                                       (pose["x"], pose["y"]), margin=self.margin)
            except self._NoPath as exc:
                self.no_path += 1
                self.path = []
                self.log.warning("reconnect: %s", exc)
        while self.path and math.hypot(self.path[0][0] - pose["x"], self.path[0][1] - pose["y"]) < 0.05:
            self.path.pop(0)
            if not self.path:
                self.arrived += 1
                if not self.to_ap:
                    # there and the link still down: the access point itself is sure to
                    # be in range (the radio model's, or a moved access point's)
                    self.to_ap = True
                    try:
                        self.path = self._plan(self.room, (pose["x"], pose["y"]),
                                               self.room.access_point, margin=self.margin)
                    except self._NoPath as exc:
                        self.no_path += 1
                        self.log.warning("reconnect: %s", exc)
        if self.path:
            self._send(drive_towards(pose, self.path[0], self.speed))
        else:
            self._send("stop")

    def _send(self, command):
        try:
            self.wheels.send(command, timeout=0.3)
        except (CommandError, ResourceLost, Refused) as exc:
            self.log.warning("wheels: %s", exc)
