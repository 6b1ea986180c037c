"""Behaviors bench/papaman_std.py deploys (imported by the runtime or an agent)."""

from __future__ import annotations

import json
import os
import threading
import time

from esair_std import Behavior
from esair_std.drivers.minlink.driver import MinLink

# deployed as papaman_std_comps:Stepper (bench/ on the path) or bench.papaman_std_comps
try:
    from small_computer_comps import Stepper
except ImportError:
    from bench.small_computer_comps import Stepper  # noqa: F401


class Blaster(Behavior):
    """Sends options['n'] copies of options['command'] to options['to'] back to back;
    provide() gives the time they took, and the wall clock (time.time()) as each one
    ended (several blasters at once: the link's sustained rate)."""

    def start(self):
        self.h = self.attach_actuator(self.options["to"])
        self.took = None
        self.errors = 0

    def run(self):
        cmd, n = self.options["command"], int(self.options["n"])
        self.done_at = []
        t0 = time.perf_counter()
        for _ in range(n):
            try:
                self.h.send(cmd, timeout=2.0)
            except Exception:  # noqa: BLE001 - counted
                self.errors += 1
            self.done_at.append(time.time())
        self.took = time.perf_counter() - t0

    def provide(self, requester):
        return {"took": self.took, "errors": self.errors,
                "done_at": getattr(self, "done_at", None)}


class TimedMinLink(MinLink):
    """The MinLink driver, noting for the bench (in options['notes'], a file of JSON
    lines, in thread and process mode alike) its in-process robot's pacer origin (wall:
    time.monotonic(), virtual seconds) and, as each servo line has been written to the
    port, the robot's virtual time, the wall time, when the command reached the resource
    host and when its write() began. With BENCH_GC=1 in the environment, every garbage
    collection of its process longer than 2 ms goes to NOTES.gc (generation, ms, when it
    began: time.monotonic())."""

    def open(self):
        super().open()
        notes = self.options["notes"]
        port = self.link._port                         # the esair:// robot
        pacer = port._pacer
        with open(notes, "a") as f:
            f.write(json.dumps({"t0_wall": pacer._t0_wall, "factor": pacer.factor,
                                "t0_virtual": pacer._t0_virtual / 1e9}) + "\n")
        write = port.write
        knee = self.children["servo.l_knee"]
        ran: list[tuple] = []                          # (asked, write() began) of knee commands
        knee_write = knee.write

        def timed_knee(command, _write=knee_write):    # the host thread runs the command
            esair = knee._esair
            ran.append((esair.asked, time.monotonic()))
            return _write(command)

        def timed_write(data, _write=write):           # the port's virtual time at the write
            t_wall = time.monotonic()
            out = _write(data)
            if data.lstrip(b"\r\n")[:1] == b"o":
                t = port.emulator.clock.now / 1e9
                asked, began = ran.pop(0) if ran else (None, None)
                with open(notes, "a") as f:
                    f.write(json.dumps({"written": t, "wall": t_wall, "asked": asked,
                                        "began": began, "behind": self.link.in_flight - 1,
                                        "by": threading.current_thread().name}) + "\n")
            return out

        knee.write = timed_knee
        port.write = timed_write                       # the Link calls its port's write
        if os.environ.get("BENCH_GC"):                # how long this process's GC pauses
            import gc
            started: list[float] = []

            def on_gc(phase, info, _notes=notes):
                if phase == "start":
                    started[:] = [time.monotonic()]
                elif started:
                    took = time.monotonic() - started[0]
                    if took > 0.002:
                        with open(_notes + ".gc", "a") as f:
                            f.write(json.dumps({"gen": info["generation"], "ms": took * 1e3,
                                                "t": started[0]}) + "\n")
            gc.callbacks.append(on_gc)

class Sweep(Behavior):
    """Commands the robot's 12 servos in turn, back and forth by 5 degrees around their
    stand angles, one command in flight, as fast as the link answers, for
    options['seconds'] (the robot busy while the HMI is watched: bench/hmi_figures.py); then
    provide() gives the commands sent and failed."""

    SERVOS = ("l_hip_yaw", "l_hip_roll", "l_hip_pitch", "l_knee", "l_ankle_pitch", "l_ankle_roll",
              "r_hip_yaw", "r_hip_roll", "r_hip_pitch", "r_knee", "r_ankle_pitch", "r_ankle_roll")

    def start(self):
        self.h = [self.attach_actuator(f"papaman.servo.{s}") for s in self.SERVOS]
        self.sent = self.errors = 0

    def run(self):
        i, end = 0, time.monotonic() + float(self.options["seconds"])
        while not self.stopping and time.monotonic() < end:
            try:
                self.h[i % 12].send({"angle": 90 + (5 if (i // 12) % 2 else -5), "speed": 0},
                                    timeout=1.0)
                self.sent += 1
            except Exception:  # noqa: BLE001 - counted
                self.errors += 1
            i += 1

    def provide(self, requester):
        return {"sent": self.sent, "errors": self.errors}
