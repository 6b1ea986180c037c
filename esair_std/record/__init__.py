"""Recordings of a running robot in MCAP (docs/hmi.md): ``esair std record`` writes every
sample of the sensors it watches (JSON messages with a JSON schema, one channel per
sensor, its sequence number and time stamp kept), so Foxglove, Lichtblick and
PlotJuggler open it; :class:`~.replay.Replay` publishes a recording again as sensors."""

from .mcapio import COMMAND_SCHEMA, SCHEMA, read_commands, read_latch, read_samples
from .recorder import Recorder

__all__ = ["COMMAND_SCHEMA", "SCHEMA", "Recorder", "read_commands", "read_latch", "read_samples"]
