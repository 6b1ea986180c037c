"""Components of bench/starfish_net.py: on the robot, a camera's pictures and the
microphone array's frames as sensors at a given rate (the real encoders: the camera's
320x240 render of the example room, the frames' wire format); on the remote center, a
behavior that counts what arrives (sequence holes, latency from the sample's own time)."""

from __future__ import annotations

import base64
import time

from esair_std import Behavior, Sensor


class Pictures(Sensor):
    """320x240 pictures of the example room at option ``rate`` a second, as the camera
    encodes them: ``kind`` png or jpeg."""

    def open(self):
        from esair_std.drivers.starfish.camera import Camera, encode
        from esair_std.drivers.starfish.scene import load_scene
        room = load_scene(self.options["room_file"])
        img = Camera(room).render((1.0, 1.0, 0.8))
        kind = self.options.get("kind", "png")
        data = encode(img, kind)
        self.image = base64.b64encode(data).decode("ascii")
        self.kind, self.seq = kind, 0
        self.rate_hz = float(self.options.get("rate", 10))

    def read(self):
        self.seq += 1
        return {"seq": self.seq, "t": time.time(), "format": self.kind, "w": 320, "h": 240,
                "image": self.image}


class Frames(Sensor):
    """Microphone frames (4 x 1024 int16, the driver's wire format) at option ``rate``."""

    def open(self):
        import numpy as np

        from esair_std.drivers.starfish.mics import encode_frame
        rng = np.random.default_rng(0)
        self.pcm = rng.integers(-3000, 3000, size=(1024, 4), dtype=np.int16)
        self.encode, self.seq = encode_frame, 0
        self.mics = [[0.085, 0.085], [-0.085, 0.085], [-0.085, -0.085], [0.085, -0.085]]
        self.rate_hz = float(self.options.get("rate", 15.625))

    def read(self):
        self.seq += 1
        return self.encode(self.pcm, self.seq, (self.seq - 1) * 1024, self.mics, time.time())


class Count(Behavior):
    """Counts the samples of option ``sensor`` by their own ``seq``: holes, latency
    (arrival - the sample's ``t``: one clock, the namespaces share it), bytes."""

    period = 0.005

    def start(self):
        self.h = self.attach_sensor(self.options["sensor"], keep=4096)
        self.count, self.first, self.last, self.lost = 0, None, None, 0
        self.lat: list[float] = []
        self.t_first = self.t_last = None

    def step(self):
        now = time.time()
        for s in self.h.samples():
            seq = s.value["seq"]
            if self.last is not None and seq > self.last + 1:
                self.lost += seq - self.last - 1
            if self.first is None:
                self.first, self.t_first = seq, now
            self.last, self.t_last = seq, now
            self.count += 1
            self.lat.append(now - s.value["t"])

    def provide(self, requester):
        lat = sorted(self.lat)
        def q(p):
            return lat[min(len(lat) - 1, int(p * len(lat)))] if lat else None
        return {"count": self.count, "first": self.first, "last": self.last, "lost": self.lost,
                "overwritten": self.h.overwritten, "t_first": self.t_first, "t_last": self.t_last,
                "p50": q(0.5), "p99": q(0.99)}
