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
import statistics
import time
from pathlib import Path
from typing import TYPE_CHECKING

from esair_std import Behavior, CommandError, Reaction, Refused, ResourceLost

if TYPE_CHECKING:  # pragma: no cover
    from esair_std.drivers.starfish.gccphat import Localizer

# numpy (the room, the planner, GCC-PHAT) is imported in start() by the
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


#: patrol's drive is steady while its commands stay within this of one (mm/s, each axis):
#: the wheels are then at that drive's speeds, give or take this, once it has ramped in
STEADY_MM_S = 15


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
        self.laps = 0
        # (time.monotonic(), mm/s) of the drive commands sent lately: the fastest is in
        # patrol's answer (turn_and_shoot's start while the drive ramps out)
        self.drives: collections.deque[tuple[float, float]] = collections.deque(maxlen=16)
        self.last_drive = (0.0, 0, 0)       # (when, vx, vy) of the last drive command
        # the drive command since when it stayed within STEADY_MM_S of this one
        self.steady = (0.0, 0, 0)
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
            # yielded: the taker commands the wheels at once (a stop sent now would
            # land in the middle of its turn)
            return                          # reconnect drives while the link is down
        target = self.waypoints[self.index]
        if math.hypot(target[0] - pose.value["x"], target[1] - pose.value["y"]) < self.tolerance:
            self.reached += 1
            self.index = (self.index + 1) % len(self.waypoints)
            self.laps += self.index == 0
            target = self.waypoints[self.index]
        drive = drive_towards(pose.value, target, self.speed)
        now = time.monotonic()
        self.drives.append((now, math.hypot(drive["vx"], drive["vy"])))
        self.last_drive = (now, drive["vx"], drive["vy"])
        if max(abs(drive["vx"] - self.steady[1]), abs(drive["vy"] - self.steady[2])) > STEADY_MM_S:
            self.steady = (now, drive["vx"], drive["vy"])
        self._send(drive)

    def _send(self, command) -> bool:
        try:
            self.wheels.send(command, timeout=0.3)
            return True
        except (CommandError, ResourceLost, Refused) as exc:
            self.log.warning("wheels: %s", exc)
            return False

    def provide(self, requester):
        # the fastest drive commanded within the last 0.5 s: the wheels are at most there
        now = time.monotonic()
        drive = max((v for t, v in self.drives if t > now - 0.5), default=0.0)
        t, vx, vy = self.last_drive
        return {"waypoint": self.index, "reached": self.reached, "laps": self.laps,
                "link_losses": self.link_losses, "drive_mm_s": round(drive),
                # the last drive command (robot frame), while the wheels may still hold it
                "drive": [vx, vy] if t > now - 0.5 else [0, 0],
                # how long the drive commanded has stayed within STEADY_MM_S of it
                "drive_steady_s": round(now - self.steady[0], 3) if t > now - 0.5 else 0.0,
                "yielded_to": self.yielded_to if now < self.yielded_until else None}


class Localize(Behavior):
    period = 0.05
    deadline = 3.0

    def start(self):
        from esair_std.drivers.starfish.gccphat import Localizer   # numpy: remote side
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
        self.next_due: float | None = None      # when the next frame should arrive
        self.last_step = 0.0
        self.gap = float(self.period or 0.02)   # between two steps, smoothed
        self.awaited = 0                         # frames taken up inside a step

    def step(self):
        now = time.time()
        if self.last_step:
            self.gap += 0.2 * (now - self.last_step - self.gap)
        self.last_step = now
        self._localize(self.mics.samples())
        # the next frame, due before the next step, is waited for here and taken up as
        # it comes (a sound's first frame is heard up to a period sooner), polled every
        # 2 ms from just before it is due
        due, now = self.next_due, time.time()
        if due is None or now >= due + AWAIT_FRAME_S or due - now >= self.gap:
            return
        end = due + AWAIT_FRAME_S
        time.sleep(max(0.0, due - AWAIT_EARLY_S - now))   # asleep until it is nearly due
        while time.time() < end:
            time.sleep(0.002)
            frames = self.mics.samples()
            if frames:
                self.awaited += 1
                self._localize(frames)
                return

    def _localize(self, frames: list) -> None:
        last = frames[-1].value if frames else None
        if isinstance(last, dict) and isinstance(last.get("n"), int) and \
                isinstance(last.get("rate"), int) and last["rate"] > 0:
            self.next_due = frames[-1].t + last["n"] / last["rate"]
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
                "skipped": self.skipped, "awaited": self.awaited,
                "bad_frames": self.bad_frames,
                "confident": self.confident, "published": self.published,
                "overwritten": self.mics.overwritten}


#: a frame due before localize's next step is waited for inside the step, from this long
#: before it is due, until this long after (the sensor's poll, its hop to the behavior)
AWAIT_EARLY_S = 0.002
AWAIT_FRAME_S = 0.015
#: the standing frame by the ramp model (TurnAndShoot._at_rest): read this long after the
#: model's rest (a control tick of each board), and what the robot may still turn after it
REST_MARGIN_S = 0.02
#: ... when the odometry says when the board read it (tn, omnilink.Odometry): the frame's
#: own time is the board's, and a frame read from the model's rest sees it (the drive
#: board's ramp, a step each tick, rests by the model's, _landing)
REST_MARGIN_TN_S = 0.0
REST_LEFT_RAD = math.radians(0.1)
#: the aim's closed-loop check while the robot ramps down (TurnAndShoot._check): the
#: first odometry frame read FIT_AFTER_S after the stop's landing (the model's) tells
#: when it landed (turn.fit_stop, within FIT_SPREAD_S of the model's); a miss it predicts
#: beyond FIT_MISS_RAD (a stop held up: the frame's counts' noise alone moves the
#: prediction by a degree) starts the one correction then, a creep the rest of the way,
#: its rate the miss over CREEP_S, at most CREEP_MAX rad/s; a smaller one is left to the
#: standing frame
FIT_AFTER_S = 0.05
FIT_SPREAD_S = 0.2
FIT_MISS_RAD = math.radians(3.0)
CREEP_S = 0.06
CREEP_MAX = 0.6
#: the flow sensors' speed a turn started while patrol drives keeps under, as a share of
#: their top (turn.start_plan; the model's ramp is smooth, the board's in steps)
START_LIMIT = 0.75
#: ... when patrol's drive has been steady this long (its commands within STEADY_MM_S: a
#: reversal at 250 mm/s has ramped in); else the fixed slow start
STEADY_S = 0.3
#: ... and kept under when the top rate lands this much sooner after the first command
#: than planned (each lands on the drive board's tick; the first may come late)
START_MARGIN_S = 0.03
#: the share of a first aim's miss (as a time: over the rate it stopped from) the stops'
#: lead takes up (the drive board's tick alone moves a landing by up to 10 ms)
LEARN = 0.3
#: ... within a tick of the drive board either way (a stop held up longer by a loaded
#: computer is not learned)
LEAD_MAX = 0.01
#: a stop found further ahead than this is planned again from each odometry frame that
#: comes before it (TurnAndShoot._stop_due)
REPLAN_S = 0.03
#: the standing frame is waited for inside a step until this long after the model's rest
#: (the poll at rest, its reply on the line, the driver's hop)
AWAIT_STAND_S = 0.05


class TurnAndShoot(Behavior):
    period = 0.02
    deadline = 3.0

    @classmethod
    def prepare_entry(cls, options: dict, base_dir: str | None, name: str) -> dict:
        """The turn's limits from the board files (option ``robot``, default
        ``starfish``), as plain data: ``esair std run`` calls it where the deployment is
        checked, so that the robot side never imports the board model (pydantic);
        ``start`` calls it when it was not (a remote agent). Raises ValueError naming
        the robot for one that is missing, bad, or has no omni base."""
        from esair_std.drivers.starfish.omniboard import prepare_omni
        omni, _path, inputs = prepare_omni(str(options.get("robot", "starfish")),
                                           Path(base_dir or "."))
        return {"omni": omni.to_json(), "inputs": inputs}

    def start(self):
        from esair_std.drivers.starfish import turn
        from esair_std.drivers.starfish.omniboard import OmniBoard
        self._turn = turn
        self.patrol = self.options.get("patrol", "patrol")
        self.tolerance = math.radians(float(self.options.get("tolerance_deg", 1.5)))
        # the correction's top rate (rad/s): slow enough that a wheel command's late
        # arrival (tens of ms on a loaded computer) moves the aim by a fraction of a degree
        self.correction_rate = float(self.options.get("correction_rate", 0.25))
        # the turn's limits from the board files: the top rate and the drive board's ramp
        spec = self._esair.spec
        prepared: dict = spec.prepared if isinstance(spec.prepared, dict) else {}
        omni = prepared.get("omni")
        robot = OmniBoard.from_json(omni) if isinstance(omni, dict) else None
        if robot is None or not robot.has_turn:        # not prepared beforehand
            robot = OmniBoard.from_json(
                self.prepare_entry(dict(self.options), spec.base_dir, self.name)["omni"])
        self.robot = robot
        omega, self.accel = turn.turn_limits(robot)
        # the flow sensors lose counts beyond their top speed: while the patrol's drive
        # ramps out, the turn starts slower, so the odometry keeps the heading
        self.flow_max, self.flow_r = turn.flow_limit(robot)
        self.wheel_r = turn.wheel_radius(robot)
        self.max_drive = turn.max_speed(robot)
        # the odometry's times from the central board's own tick count (its samples
        # reach this behavior a varying while after the board read the sensors)
        self.tick = robot.board.tick_s
        # the line: a byte's time, and the bytes of a stop and of a velocity line (their
        # CR is decoded (n - 1) bytes after the first leaves)
        self.byte = 10.0 / robot.board.baud
        extra = 3 if robot.board.checksum else 0
        self.x_bytes, self.v_bytes = 3 + extra, 18 + extra
        # the odometry says when the board read each frame (its tn)
        self.timed = False
        # one way from this behavior to the robot's line: half of what the wheel
        # commands' round trips take beyond their bytes on the line (median of the last)
        self.h = 0.001
        self.hs: collections.deque[float] = collections.deque(maxlen=7)
        self.offsets: collections.deque[float] = collections.deque(maxlen=10)
        self.n_prev: int | None = None
        self.n_wraps = 0
        self.going = False
        self.last_step = 0.0
        self.gap = self.period              # between two steps, smoothed
        # patrol's step under way when it was asked to yield may still send a drive
        # command: when patrol's answer to a get (after the yield) does not come, the
        # turn counts on this long for it
        self.handover = float(self.options.get("handover_s", 0.06))
        self.handed = False
        self.patrol_drive: float | None = None      # patrol's answer: its drive lately
        self.drive_steady = 0.0                     # ... and how long it has been steady
        self.drive_cmd: tuple[float, float] | None = None   # ... and its last command
        # the slow start's rate while patrol's drive ramps out: the wheels ramp one by
        # one, and a faster turn would take a flow sensor past its top speed
        self.start_rate = float(self.options.get("start_rate", 1.2))
        # the central board stops the wheels when no command came for 0.5 s: the turn's
        # rate is sent again after this long
        self.refeed = float(self.options.get("refeed_s", 0.2))
        # what a drive command landing during the handover can add before the next turn
        # command replaces it (the drive's ramp over two of this behavior's periods)
        self.handover_mm_s = self.accel * self.wheel_r * 2 * self.period
        self.max_turn = min(float(self.options.get("max_turn", omega * 1000)), omega * 1000)
        self.cooldown = float(self.options.get("cooldown", 5.0))          # s between shots
        self.turn_timeout = float(self.options.get("turn_timeout", 6.0))
        # a wheel command refused, failed or unanswered is logged and the next step sends
        # again; the shot is given up only when no wheel command went through for this long
        self.wheels_silent = float(self.options.get("wheels_silent_s", 2.0))
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
        # the turn's odometry: (the board's time, turned rad), and the stop's
        self.odo: tuple[float, float] = (0.0, 0.0)
        self.anchor = self.odo
        self.stop_sent, self.stood = 0.0, False
        self.rest_at: float | None = None
        self.since = 0.0
        self.quiet_until = 0.0
        self.pictures = []
        self.shots = self.aborted = self.ignored = self.missed = 0
        self.wheels_ok_at = 0.0             # when a wheel command last went through
        # a wheel command's round trip: the median of the last few (one reply late on a
        # loaded computer must not move every later command's expected arrival)
        self.rtt = 0.02
        self.rtts: collections.deque[float] = collections.deque([0.02], maxlen=7)
        # what the stops' landing needs beyond that, learned from the first aims' misses
        self.lead = 0.0
        self.stop_rate = 0.0
        self.sign = 1.0
        self.back = False                   # a correction turning back (an overshoot)
        self.landing = 0.0                  # when the model has the first stop land
        self.checked = False                # the first stop's landing fitted (_check)
        self.turn: dict = {}
        self.last_xy: tuple[float, float, float, float] | None = None
        self.vel: tuple[float, float, float] | None = None     # (t, vx, vy) from the odometry
        self.moved: collections.deque[bool] = collections.deque(maxlen=2)   # the last frames
        # (t, translation speed mm/s) from the odometry
        self.drives: collections.deque[tuple[float, float, float]] = collections.deque(maxlen=10)

    def receive(self, sender, data):
        if self.phase != "idle" or time.monotonic() < self.quiet_until:
            self.ignored += 1
            return
        self.pending = data
        # the turn starts now, on this behavior's thread, not at the next step
        self._read_odometry()
        self._act()

    def _heading_at(self, t: float | None) -> float | None:
        if not self.headings:
            return None
        if t is None:
            return self.headings[-1][1]
        return min(self.headings, key=lambda h: abs(h[0] - t))[1]

    def step(self):
        now = time.time()
        if self.last_step:
            self.gap += 0.2 * (now - self.last_step - self.gap)
        self.last_step = now
        self._read_odometry()
        self._act()

    def _read_odometry(self):
        for s in self.odometry.samples():
            # every sample's board time: the offsets are the last 10 samples' (a lagging
            # emulator moves them; ones from an earlier turn would time this one early)
            board_t = self._board_time(s)
            self.timed = isinstance(s.value.get("tn"), (int, float))
            if self.phase in ("turning", "settling") and self.headings:
                self.turned += self.sign * wrap(s.value["th"] - self.headings[-1][1])
                prev, self.odo = self.odo, (board_t, self.turned)
                if self.phase == "settling" and self.stop_sent and s.t > self.stop_sent and \
                        not self.stood:
                    if not s.value.get("moving", True):
                        self.stood, self.turn["rest"] = True, "still"
                    elif self._at_rest(prev):
                        self.stood, self.turn["rest"] = True, "model"
            if self.last_xy is not None and s.t > self.last_xy[0]:
                moved = math.hypot(s.value["x"] - self.last_xy[1], s.value["y"] - self.last_xy[2])
                self.drives.append((s.t, 1000 * moved / (s.t - self.last_xy[0]), s.t - self.last_xy[0]))
                if board_t > self.last_xy[3]:
                    # the robot's velocity over the frame (mm/s, its frame), at its middle
                    dx, dy = s.value["x"] - self.last_xy[1], s.value["y"] - self.last_xy[2]
                    c, n = math.cos(s.value["th"]), math.sin(s.value["th"])
                    dt = board_t - self.last_xy[3]
                    self.vel = ((board_t + self.last_xy[3]) / 2, 1000 * (c * dx + n * dy) / dt,
                                1000 * (-n * dx + c * dy) / dt)
            self.last_xy = (s.t, s.value["x"], s.value["y"], board_t)
            self.moved.append(bool(s.value.get("moving", True)))
            self.headings.append((s.t, s.value["th"]))

    def _act(self):
        if self.phase == "idle" and self.pending is not None:
            data, self.pending = self.pending, None
            th = self._heading_at(data.get("t"))
            if th is None:
                return
            self.target = wrap(th + float(data["bearing"]))
            self.bearing = data
            self.put(self.patrol, {"yield": self.turn_timeout + 2.0}, timeout=0.3)
            # patrol answers from its own thread after it took the yield: a drive command
            # its step had under way has landed, and it sends no more
            answer = self.get(self.patrol, timeout=0.3)
            self.handed = isinstance(answer, dict)
            self.patrol_drive = answer.get("drive_mm_s") if self.handed else None
            steady = answer.get("drive_steady_s") if self.handed else None
            self.drive_steady = float(steady) if isinstance(steady, (int, float)) else 0.0
            drive = answer.get("drive") if self.handed else None
            self.drive_cmd = (float(drive[0]), float(drive[1])) if isinstance(drive, list) and \
                len(drive) == 2 and all(isinstance(v, (int, float)) for v in drive) else None
            self.since = time.monotonic()
            self.wheels_ok_at = self.since
            # the turn's record: its first aim, corrections, top rate commanded, and when
            # (time.time()) the bearing was taken up, the wheels went, stopped, stood
            self.turn = {"deg": 0.0, "corrections": -1, "max_w": 0, "target": round(self.target, 5),
                         "at": {"heard": time.time()}}
            self._aim()
        if self.phase == "idle":
            return
        try:
            if time.monotonic() - self.since > self.turn_timeout:
                self._wheels("stop")
                self.aborted += 1
                self._done()
            elif self.phase == "turning":
                self._turning()
            elif self.phase == "settling":
                if self.stop_sent == 0.0:
                    self._stop()            # the stop's reply was missed: again
                elif self._check():
                    pass                    # the one correction, from the odometry
                elif self._await_stand() or self.stood:
                    err = wrap(self.target - self.headings[-1][1])
                    if self.turn["corrections"] == 0:
                        self._learn(err)
                    self.turn.setdefault("miss_deg", round(math.degrees(err), 2))
                    self.turn["aim_deg"] = round(math.degrees(err), 2)   # the last stand's
                    self.turn["at"][self._key("stood")] = time.time()
                    if abs(err) > self.tolerance and self.turn["corrections"] < 1:
                        self._aim()         # the one correction, from the odometry
                        if self.phase == "turning":
                            self._turning()     # its creep goes now, not at the next step
                    else:
                        self.turn["odo_th"] = self.headings[-1][1]
                        self._shoot()
                        self._done()
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

    def _board_time(self, s) -> float:
        """When the central board read the sample, on this computer's clock: the
        driver's ``tn`` where it gives one; else its tick count against the least
        delayed of the recent samples, the sample's own time when the two disagree by
        more than a reply's delay (a lagging board, a restart)."""
        tn = s.value.get("tn")
        if isinstance(tn, (int, float)) and s.t - 0.5 <= tn <= s.t:
            return float(tn)
        n = s.value.get("n")
        if not isinstance(n, int):
            return float(s.t)
        if self.n_prev is not None and n < self.n_prev:
            self.n_wraps += 1               # 16 bits, or a restarted board: a new base
            self.offsets.clear()
        self.n_prev = n
        board = (n + 65536 * self.n_wraps) * self.tick
        self.offsets.append(s.t - board)
        t = board + min(self.offsets)
        return t if s.t - 0.05 <= t <= s.t else float(s.t)

    def _aim(self):
        """Start a turn to ``target`` from the latest heading: the top rate, stopped when
        the ramp down will end at the target (the profile); the odometry corrects the
        model's prediction on the way."""
        angle = wrap(self.target - self.headings[-1][1]) if self.headings else 0.0
        self.turn["corrections"] += 1
        if self.turn["corrections"] == 0:
            self.turn["deg"] = round(math.degrees(angle), 2)
        self.sign = 1.0 if angle >= 0 else -1.0
        self.goal, self.turned = abs(angle), 0.0
        # the ramp wheel by wheel, from patrol's drive (the first aim) or from standing
        drive = self.drive_cmd if self.turn["corrections"] == 0 and self.drive_cmd else (0.0, 0.0)
        rims = None
        if self.turn["corrections"] == 0 and self.drive_cmd and self.vel is not None and \
                self.drive_steady < STEADY_S:
            rims = self._rims_at_go(drive)      # patrol's drive still ramping in
            self.turn["drive_ramping"] = True
        self.model = self._turn.WheelRamp(self.robot, drive, self.sign, rims)
        self.odo = (self.headings[-1][0] if self.headings else time.time(), 0.0)
        self.stop_sent, self.stood = 0.0, False
        self.stop_rate = 0.0                # the model's rate when the stop was sent
        self.back, self.checked = False, False
        self.rest_at = None                 # when the model has it come to rest
        self.anchor = self.odo              # the odometry the stop was planned from
        self.going = False
        self.sent = (0, 0.0)                # the last rate sent (mrad/s), when
        # driving: turn at what the flow sensors can follow until the drive has ramped out
        # the odometry's speed is a frame's mean and lags a robot speeding up (patrol's
        # ramp): the most it can be now, from the last frame on at the drive's ramp; and
        # patrol may send one more drive command while its yield is on its way (its
        # period: handover_s), so the turn starts at what the flow sensors can follow
        # until whatever drive there is has ramped out
        v = 0.0
        known = self.handed and isinstance(self.patrol_drive, (int, float))
        if self.turn["corrections"] == 0 and known:
            # what patrol commanded lately bounds the wheels (the odometry's speed lags a
            # robot speeding up, and is a frame old)
            v = min(self.max_drive, float(self.patrol_drive))  # type: ignore[arg-type]
        elif self.turn["corrections"] == 0 and self.drives and any(self.moved):
            t_last, v_last, dt = self.drives[-1]
            top = max(sp for t, sp, _ in self.drives if t > t_last - 1.0)
            v = 1.05 * top + 20.0           # the flow counts' noise
            if len(self.drives) > 1 and v_last > self.drives[-2][1] + 30.0:     # speeding up
                v = max(v, v_last + self.accel * self.wheel_r * (time.time() - t_last + dt))
            v = min(self.max_drive, v)
        self.turn.setdefault("drive_mm_s", round(v))
        self.top = self.max_turn / 1000.0
        if self.turn["corrections"] > 0:
            # a creep as the one started while ramping down (_check): the miss over
            # CREEP_S, at most CREEP_MAX (a stop landing 10 ms late moves it by 0.35 deg,
            # one held up 50 ms by a loaded computer 1.7 deg), at least correction_rate
            self.top = min(self.top, CREEP_MAX, max(self.correction_rate, abs(angle) / CREEP_S))
        self.slow_until, self.slow_rate, self.slow_for = 0.0, self.top, 0.0
        if self.turn["corrections"] == 0:
            handover = 0.0 if self.handed else self.handover
            if not self.handed:
                v = max(v, self.handover_mm_s)
            plan = (0.0, 0.0)
            if v > 0 and self.handed and self.drive_cmd and self.drive_steady >= STEADY_S:
                # patrol's drive known and steady (the wheels at its speeds): the start
                # the wheel-by-wheel ramp says keeps every flow sensor under START_LIMIT
                # of its top while that drive ramps out (turn.start_plan)
                plan = self._turn.start_plan(self.robot, self.drive_cmd, self.sign, self.top,
                                             START_LIMIT * self.flow_max, START_MARGIN_S)
            if plan[0] > 0:
                self.slow_rate, self.slow_for = plan
            elif v > 0:
                # the start rate while the drive ramps out (its largest wheel change, at
                # the drive board's ramp, and a control tick); faster where the sensors'
                # speed, the drive's plus the turn's, stays under their top
                self.slow_rate = min(self.top, max(self.start_rate,
                                                   (0.85 * self.flow_max - v) / self.flow_r))
                self.slow_for = handover + v / (self.accel * self.wheel_r) + 0.02
            self.turn["start"] = [round(1000 * self.slow_rate), round(1000 * self.slow_for),
                                  self.handed]
        self.phase = "turning" if abs(angle) > self.tolerance else "settling"

    def _turning(self):
        rate = self.top
        if self.going and 0 < self.slow_until - time.time() < 1.5 * self.gap:
            time.sleep(self.slow_until - time.time())     # the slow start's end, on time
        if (self.slow_for and not self.going) or time.time() < self.slow_until:
            rate = min(rate, self.slow_rate)
        # the stop is looked for over the next two steps or so (steps come late on a
        # loaded computer, and a stop found late overshoots); a step waits 0.25 s at most
        if self.going and self._stop_due(min(0.25, max(0.1, 2.5 * self.gap))):
            return
        w = round(self.sign * rate * 1000)
        t0 = time.time()
        # the drive board holds the rate: past the handover (patrol's last command may
        # land after the first turn command) it is sent again only when it changes or
        # the board's watchdog would stop the robot, so a slow reply rarely holds up the stop
        handover = t0 - self.turn["at"].get("go", t0) < 0.2
        if self.going and not handover and w == self.sent[0] and t0 - self.sent[1] < self.refeed:
            return
        self._wheels({"w": w})
        t1 = time.time()
        landed = self._landing(t0, self.v_bytes, t1)
        if self.going and self.slow_for and w != self.sent[0]:
            self.model.command(landed, rate)      # the slow start ended: when it did
        self.sent = (w, t0)
        self.rtts.append(t1 - t0)
        self.rtt = statistics.median(self.rtts)
        self.turn["max_w"] = max(self.turn["max_w"], abs(w))
        if not self.going:                  # the wheels ramp up from here
            self.going = True
            self.turn["at"][self._key("go")] = t0
            self.model.command(landed, rate)
            if self.slow_for:
                # the top rate enters the model when it is sent (the stop is not looked
                # for past then: a stop the model found beyond would skip the fast part)
                self.slow_until = landed + self.slow_for
            if self.turn["corrections"] > 0:
                # the correction, short and from standing: its stop planned now and
                # waited for here rather than at the mercy of the next steps
                self._stop_due(0.4)
                return
        # a stop due soon after this command (a short turn's, right after the slow
        # start) is waited for now, not found late by the next step
        self._stop_due(min(0.25, max(0.1, 2.5 * self.gap)))

    def _stop_due(self, horizon: float) -> bool:
        """Send the stop if it is due within ``horizon`` s (waiting for its moment); not
        past the slow start's end, whose rate a later step has still to send."""
        now = time.time()
        if self.slow_until > now:
            horizon = min(horizon, self.slow_until - now)
        t_stop = self._turn.stop_time(self.model, self.odo[1], self.odo[0], now,
                                      self.goal, self._stop_latency(), horizon, self.back)
        # waited for here, and planned again from each frame that comes meanwhile (a
        # short turn's stop, found right after its slow start, was planned from a frame
        # of the drive's ramp-out: 3-6 deg off) until it is REPLAN_S away
        while t_stop is not None and t_stop - time.time() > REPLAN_S:
            time.sleep(min(0.005, t_stop - time.time() - REPLAN_S))
            frame = self.odo
            self._read_odometry()
            if self.odo is not frame and self.phase == "turning":
                now = time.time()
                t_stop = self._turn.stop_time(self.model, self.odo[1], self.odo[0], now,
                                              self.goal, self._stop_latency(),
                                              t_stop - now + REPLAN_S, self.back)
        if t_stop is None:
            return False
        time.sleep(max(0.0, t_stop - time.time()))
        self._stop()
        return True

    def _stop_latency(self) -> float:
        """From sending the stop to its landing (_landing)."""
        return self._landing(0.0, self.x_bytes)

    def _rims_at_go(self, drive: tuple[float, float]) -> list[float]:
        """Each wheel's rim speed (mm/s) when the turn's first command lands, while
        patrol's last drive command is still ramping in: from the odometry's velocity
        (over its last frame) toward that drive's, at each wheel's ramp."""
        t_v, vx, vy = self.vel                  # type: ignore[misc]  # checked by the caller
        probe = self._turn.WheelRamp(self.robot)
        t_go = self._landing(time.time(), self.v_bytes)
        out = []
        for row, ramp in zip(probe.rows, probe.ramps):
            now, to = row[0] * vx + row[1] * vy, row[0] * drive[0] + row[1] * drive[1]
            step = ramp * max(0.0, t_go - t_v)
            out.append(now + max(-step, min(step, to - now)))
        return out

    def _landing(self, t_send: float, nbytes: int, t_back: float | None = None) -> float:
        """When a command of ``nbytes`` sent at ``t_send`` takes effect, for the ramp
        model, and the lead learned from the first aims' misses. The drive board takes it
        at its next control tick (its own clock: 0-10 ms after the line is decoded) and
        ramps a step each tick from there, as the model's ramp from half a tick before
        (the same speed in the middle of each tick): on average, from the line's
        decoding, one way (``h``) and its bytes after it was sent. Without the frames'
        own times (untimed odometry) the model's times are the host's: the middle of the
        command's round trip (``t_back``, else the usual) and half a tick."""
        if self.timed:
            return t_send + self.h + (nbytes - 1) * self.byte + self.lead
        back = t_send + self.rtt if t_back is None else t_back
        return (t_send + back) / 2 + 0.005 + (self.lead if t_back is None else 0.0)

    def _at_rest(self, prev: tuple[float, float]) -> bool:
        """Does the odometry frame just read (``self.odo``, after ``prev``) see the
        robot at rest by the ramp model (turn.seen_at_rest)?"""
        if self.rest_at is None:
            return False
        margin = REST_MARGIN_TN_S if self.timed else REST_MARGIN_S
        return self._turn.seen_at_rest(self.model, [self.anchor, prev, self.odo], self.rest_at,
                                       self.stop_rate, margin, REST_LEFT_RAD, self.back)

    def _await_stand(self) -> bool:
        """The frame that sees the robot stand (the driver polls the odometry when the
        wheels come to rest) is waited for in this step when it is due before the next
        one, and taken as it arrives; True when it came."""
        if self.stood or self.rest_at is None or not self.timed:
            return self.stood
        end = self.rest_at + AWAIT_STAND_S
        if time.time() < self.rest_at - 1.5 * self.gap:
            return False
        while not self.stood and time.time() < end:
            time.sleep(0.002)
            self._read_odometry()
        return self.stood

    def _check(self) -> bool:
        """The aim's closed-loop check, while the first stop ramps the robot down: the
        first odometry frame read FIT_AFTER_S after the stop's landing (the model's) says
        when it landed (turn.fit_stop) and so where the robot will rest; off by more than
        FIT_MISS_RAD (a stop held up), the one correction starts at once, before it
        stands: a creep on toward the target (the wheels ramp down to it) or back (down
        through standing). True when it started; otherwise the model stays as it was and
        the standing frame tells the miss."""
        if self.checked or self.turn["corrections"] != 0 or not self.going or \
                self.odo[0] < self.landing + FIT_AFTER_S:
            return False
        self.checked = True
        t_model = self.landing
        t_land, inside = self._turn.fit_stop(self.model, self.anchor, self.odo, FIT_SPREAD_S)
        if not inside and t_land >= self.odo[0] - 1e-4:
            # it had not landed when this frame was read (held up): the next frame
            self.model.changes[-1] = (t_model, 0.0)
            self.checked = False
            return False
        late = t_land - t_model
        self.turn["landed_ms"] = round(1000 * late, 1)
        err = self.goal - self._turn.rest_angle(self.model, self.anchor)     # > 0: short
        self.turn["fit_deg"] = round(math.degrees(self.sign * err), 2)
        if abs(err) <= max(self.tolerance, FIT_MISS_RAD) or not inside:
            self.model.changes[-1] = (t_model, 0.0)
            return False
        self.turn["miss_deg"] = round(math.degrees(self.sign * err), 2)
        self.turn["corrections"] += 1
        rate = min(CREEP_MAX, max(self.correction_rate, abs(err) / CREEP_S))
        self.back = err < 0
        self.top = -rate if self.back else rate
        self.slow_until, self.slow_for = 0.0, 0.0
        self.stood, self.rest_at, self.stop_rate = False, None, 0.0
        self.anchor = self.odo
        self.phase = "turning"
        w = round(self.sign * self.top * 1000)
        t0 = time.time()
        self._wheels({"w": w})
        self.model.command(self._landing(t0, self.v_bytes, time.time()), self.top)
        self.sent = (w, t0)
        self.turn["max_w"] = max(self.turn["max_w"], abs(w))
        self.turn["at"]["go2"] = t0
        self._stop_due(0.4)                 # planned now and waited for (as _turning's)
        return True

    def _learn(self, err: float) -> None:
        """The stop's lead from the first aim's miss: past the target in the turn's
        direction, the stop landed later than expected by the miss over the rate it
        stopped from (a loaded computer's misses of many degrees are not learned)."""
        late = -self.sign * err / max(self.stop_rate, 1e-3)
        if self.stop_rate > 1.0 and abs(late) < LEAD_MAX:
            self.lead = max(-LEAD_MAX, min(LEAD_MAX, self.lead + LEARN * late))
        self.turn["lead_ms"] = round(1000 * self.lead, 1)

    def _stop(self):
        self.phase = "settling"
        t0 = time.time()
        if self.going:
            landing = self._landing(t0, self.x_bytes)
            if not self.stop_rate:
                self.stop_rate = abs(self.model.at(landing)[1])
            self.model.command(landing, 0.0)
            self.rest_at = landing + abs(self.model.at(landing)[1]) / self.accel
            self.anchor = self.odo
            if self.turn["corrections"] == 0:
                self.landing = landing
        self.stop_sent = 0.0
        self._wheels("stop")
        self.stop_sent = t0
        # how the landing was known: on the board's tick (True), and the one way's ms
        self.turn["timed"] = self.timed
        self.turn["h_ms"] = round(1000 * self.h, 2)
        self.turn["at"][self._key("stop")] = t0

    def _key(self, event: str) -> str:
        """The turn record's name of an event: the correction's with a 2 (go2...)."""
        return event + ("2" if self.turn["corrections"] > 0 else "")

    def _wheels(self, command):
        t0 = time.time()
        self.wheels.send(command, timeout=0.5)
        rtt = time.time() - t0
        # one way: half the round trip beyond the line's bytes (the line, and "OK")
        n = self.x_bytes if command == "stop" else self.v_bytes
        self.hs.append(max(0.0, (rtt - (n - 1 + 4) * self.byte) / 2))
        self.h = statistics.median(self.hs)
        self.wheels_ok_at = time.monotonic()

    def _shoot(self):
        pic = self.camera.send("shoot", timeout=2.0)
        self.shots += 1
        self.store.mkdir(parents=True, exist_ok=True)
        stem = f"starfish-{self.shots:05d}"
        image = base64.b64decode(pic["image"])
        (self.store / f"{stem}.{'png' if pic['format'] == 'png' else 'jpg'}").write_bytes(image)
        meta = {"file": f"{stem}.{'png' if pic['format'] == 'png' else 'jpg'}", "pose": pic["pose"],
                "t": pic["t"], "bearing": self.bearing, "bytes": len(image), "turn": self.turn}
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
