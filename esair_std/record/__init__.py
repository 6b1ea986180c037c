"""Recordings of a running robot in MCAP (docs/hmi.md): ``esair std record`` writes every
sample of the sensors it watches (JSON messages with a JSON schema, one channel per
sensor, its sequence number and time stamp kept), so Foxglove, Lichtblick and
PlotJuggler open it; :class:`~.replay.Replay` publishes a recording again as sensors.

The names below are imported on first use, so that the live Foxglove server
(:mod:`.foxserver`), which needs neither the ``mcap`` library nor the recorder, does
not load them."""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .mcapio import COMMAND_SCHEMA, SCHEMA, read_commands, read_latch, read_samples
    from .recorder import Recorder

__all__ = ["COMMAND_SCHEMA", "SCHEMA", "Recorder", "read_commands", "read_latch", "read_samples"]


def __getattr__(name: str) -> object:
    if name not in __all__:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    module = ".recorder" if name == "Recorder" else ".mcapio"
    return getattr(importlib.import_module(module, __name__), name)
