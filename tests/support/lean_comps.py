"""Components that report which modules their process has imported (the agent stays
lean: every module costs each component process RSS; see docs/std.md, Measured)."""

from __future__ import annotations

import gc
import sys

from esair_std import Behavior, Sensor

#: modules an agent process does not need (the deployment loader's pydantic and yaml,
#: the CLI's click and rich, dataclasses' inspect, argparse, socket, error-only helpers,
#: hashlib's OpenSSL: only a remote agent with credentials proves who it is)
HEAVY = ("pydantic", "yaml", "click", "rich", "jinja2", "cryptography", "dataclasses",
         "inspect", "argparse", "socket", "difflib", "pkgutil", "_hashlib")


def heavy_imported() -> list[str]:
    return [m for m in HEAVY if m in sys.modules]


class Counting(Sensor):
    """Reports 1, 2, 3... at 200 Hz; configure('modules', _) gives heavy_imported()."""

    rate_hz = 200

    def open(self):
        self.n = 0

    def read(self):
        self.n += 1
        return self.n

    def configure(self, key, value):
        if key == "modules":
            return heavy_imported()
        if key == "frozen":           # objects its process froze after start-up (heap.py)
            return gc.get_freeze_count()
        return super().configure(key, value)


class Listening(Behavior):
    """Attaches to 'count'; provide() gives (samples received, heavy_imported())."""

    period = 0.01

    def start(self):
        self.h = self.attach_sensor("count")

    def provide(self, requester):
        return [self.h.received, heavy_imported()]


class Frozen(Behavior):
    """provide(): how many objects its process froze after start-up (esair_std/heap.py)."""

    period = 0.05

    def provide(self, requester):
        return {"frozen": gc.get_freeze_count()}


#: what a robot side handed its deployment checked (esair std run, esair_std/lean/)
#: does not import: the checker's pydantic and yaml, the board model, Jinja2
CHECKER = ("pydantic", "pydantic_core", "yaml", "jinja2", "esair_min.model.board",
           "esair_min.model.robot", "esair_min.model.validate", "esair_std.deploy.loader",
           "esair_std.deploy.model")


class CheckerModules(Behavior):
    """provide(): which of CHECKER its process has imported."""

    period = 0.5

    def provide(self, requester):
        return [m for m in CHECKER if m in sys.modules]
